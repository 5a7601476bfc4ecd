#pragma once
/// \file
/// Floating-base state estimation from what a real robot measures: joint encoders and torques, a
/// pelvis IMU (gyro, accelerometer) and the ankle force/torque sensors. No simulator truth.
///
///  - Joints: positions and velocities from an α-β filter per joint (the steady-state Kalman filter
///    of a constant-velocity model), which removes encoder quantisation noise with little lag.
///  - Contact: each foot's normal ground force, from its ankle sensor plus the weight of the foot
///    below the sensor, with hysteresis (on above `contact_on`, off below `contact_off`); on level
///    ground a sole whose lowest corner is `contact_max_height` above the other's is in the air. A
///    sole in contact whose centre of pressure is within `cop_edge_margin` of its edge may be
///    rotating about that edge (heel or toe): it stays in contact, its pose corrects nothing until
///    the CoP moves back inside, and only the point of the sole at its CoP, which the rolling leaves
///    at rest, gives the velocity (`edge_velocity_noise`, while the sole carries `edge_min_load` of
///    the weight). A sole that turned in contact (faster than `anchor_max_rate`) and stops with its
///    CoP back inside has landed on its face: with `settle_after_roll`, like a touchdown, it settles
///    for 30 ms before its kinematics, which carry the impact, correct anything. A sole that is no
///    anchor (in the air, on an edge, turning, or just landed) follows the estimate; when it becomes
///    one it is seated where the estimate then puts it, so that a sole that turned or slid on its
///    edge is not pulled back to where it stood before. With `settle_at_start`, the soles standing
///    when the estimator starts settle alike.
///  - Attitude: an error-state Kalman filter on (R_WB, gyro bias b), predicted with the gyro and
///    corrected by the orientation the legs in contact give (sole flat on level ground, its yaw held
///    since it became an anchor), and without contact by the accelerometer's gravity direction.
///  - Angular velocity: ω_B fused from the gyro (less b̂) and, in contact, the leg kinematics
///    (a sole at rest gives ω_B = −J_ω,sole q̇ in the base frame), which is far less noisy than a
///    MEMS gyro at 1 kHz.
///  - Position and velocity: a linear Kalman filter on x = (p_WI, v_WI, p_W,right, p_W,left) of the
///    IMU point I, predicted with the IMU's acceleration R_WI f_I + g, corrected by the position and
///    the velocity of each sole in contact relative to I from the leg kinematics (a sole in contact
///    stays put; a sole in the air follows the leg; a sole rolling on an edge keeps its CoP point
///    at rest).
///  - CAM: a momentum observer on the centroidal angular momentum l_c,
///        l̂̇ = Σ_contacts τ_c,k + K_l (A_G,ang ν − l̂),
///    whose fast part comes from the measured contact wrenches (moments about the CoM) and slow part
///    from the kinematic momentum A_G ν; K_l (A_G,ang ν − l̂) is the torque of the unmeasured forces
///    (a push). The output rate is l̂̇.
///
/// World frame: z up, origin on the ground midway between the soles at initialisation, heading
/// from the IMU's own orientation output at initialisation (or zero when it is not valid).

#include <Eigen/Core>
#include <array>
#include <string>
#include <string_view>

#include "hpr/common/ports.hpp"
#include "hpr/common/component.hpp"
#include "hpr/common/config.hpp"
#include "hpr/common/parameters.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/model/robot.hpp"

namespace hpr::estimator {

struct EstimatorConfig {
  // Joints.
  double joint_accel_noise = 50.0;        ///< [rad/s²/√Hz] white acceleration of a joint (α-β model)
  double encoder_noise = 3e-5;            ///< [rad] (a 16-bit encoder's quantisation: 2π/2¹⁶/√12)
  bool filter_joints = true;              ///< false: q and q̇ as the drives report them
  // Attitude and angular velocity.
  double gyro_noise = 0.005;              ///< [rad/s/√Hz]
  double gyro_bias_walk = 1e-4;           ///< [rad/s²/√Hz]
  double gyro_bias_initial = 0.01;        ///< [rad/s] prior standard deviation of each bias
  double angular_accel_noise = 30.0;      ///< [rad/s²/√Hz] of the base, for the ω_B fusion
  double kinematic_orientation_noise = 2e-3;  ///< [rad] orientation of the base from a leg in contact
  double kinematic_rate_noise = 0.02;     ///< [rad/s] angular velocity of the base from a leg in contact
  double accel_orientation_noise = 0.05;  ///< [rad] gravity direction from the accelerometer
  bool level_ground = true;               ///< soles in contact are flat (roll and pitch zero)
  // Position.
  double accel_noise = 0.05;              ///< [m/s²/√Hz]
  double foot_contact_noise = 2e-4;       ///< [m/√s] random walk of a sole in contact
  double foot_swing_noise = 1.0;          ///< [m/√s] of a sole in the air
  double kinematic_position_noise = 1e-3; ///< [m]
  double kinematic_velocity_noise = 0.01; ///< [m/s]
  // Contact.
  double contact_on = 30.0;               ///< [N] normal ground force to declare contact
  double contact_off = 5.0;              ///< [N] to release it
  double cop_edge_margin = 0.01;          ///< [m] a sole whose CoP is closer than this to its edge may be
                                          ///< rotating about it: its kinematics do not correct the filters
  double anchor_max_rate = 1.0;           ///< [rad/s] a sole in contact turning faster than this is not at rest
                                          ///< either (0: no such check)
  double contact_max_height = 0.025;      ///< [m] on level ground a sole this far above the other is in the air (0: no check)
  double edge_velocity_noise = 0.0;       ///< [m/s] velocity from the CoP point of a sole rolling on its edge
                                          ///< (0: such a sole gives no velocity; the stepping overlay sets 0.03)
  double edge_min_load = 0.25;            ///< fraction of the robot's weight such a sole must carry for it (friction holds its CoP point)
  bool settle_after_roll = false;         ///< a sole that turned in contact faster than anchor_max_rate and drops back
                                          ///< flat settles as after a touchdown (the stepping overlays set it)
  bool settle_at_start = false;           ///< the soles standing at the start settle as after a touchdown: while
                                          ///< the joint filter, started at rest, converges and a sole still seats
                                          ///< itself, their kinematics correct nothing (the position coasts on the IMU)
  double anchor_velocity_gate = 0.3;      ///< [m/s] a sole whose kinematic velocity measurement differs from the
                                          ///< estimate by more than this corrects nothing (0: no gate), unless no
                                          ///< sole agrees and it has been in contact 0.1 s: then the estimate is wrong
  // Momentum observer.
  double cam_observer_gain = 20.0;        ///< K_l [1/s]
  // Health.
  double initialisation_time = 0.2;       ///< [s] flagged as initialising while the filters converge
  double max_position_std = 0.05;         ///< [m] beyond this the position filter has diverged
  double max_accel = 100.0;               ///< [m/s²] specific force beyond this is implausible
  double max_gyro = 30.0;                 ///< [rad/s]
  double max_ft_force = 5000.0;           ///< [N]
  double joint_limit_margin = 0.2;        ///< [rad] a joint this far outside its URDF range is implausible

  /// Reads and validates the `estimator` section (every key optional).
  static EstimatorConfig load(const Config& section);
};

/// The estimator's status bits, as robot_state_t::STATUS_*.
enum StatusBits : std::int32_t {
  kStatusOk = 0,
  kStatusSensorStale = 1,
  kStatusNoContact = 2,
  kStatusCovariance = 4,
  kStatusImplausible = 8,
  kStatusInitialising = 16,
};

/// Steady-state gains of the α-β filter for period dt (from the discrete Riccati equation of the
/// constant-velocity model with white acceleration noise `accel_noise` and position noise `pos_noise`).
Eigen::Vector2d alpha_beta_gains(double dt, double accel_noise, double pos_noise);

class Estimator {
 public:
  Estimator(const model::RobotSpec& robot, EstimatorConfig config);

  /// Processes one sensor sample. The first sample initialises; without a foot in contact the
  /// orientation comes from the accelerometer and the world frame is placed again at the first
  /// contact. A sample that fails the plausibility checks leaves the estimate untouched and is flagged
  /// (the returned state carries the sample's tick, so that consumers still step on it).
  const EstimatedState& update(const SensorSample& sample);
  /// The component's tick (hpr/common/component.hpp): ROBOT_SENSORS of tick k in, ROBOT_STATE of
  /// tick k out (update()), with the faults "implausible" (the refused sample's reason),
  /// "covariance" (position uncertainty too large) and "contact" (no foot in contact once
  /// initialised), not ready while it initialises.
  static constexpr std::array<std::string_view, 3> kFaultKeys{"implausible", "covariance", "contact"};
  /// The estimator process's ports.
  static constexpr Read kReads[] = {{channel::kRobotSensors, 0, true, false, "the sample it filters"}};
  static constexpr std::string_view kWrites[] = {channel::kRobotState};
  static constexpr Ports kPorts{"estimator", kReads, kWrites};
  struct Inputs {
    const SensorSample& sensors;  ///< ROBOT_SENSORS of tick k
  };
  struct Outputs {
    EstimatedState state;  ///< ROBOT_STATE of tick k
    StepReport report{kFaultKeys};
  };
  void step(const Inputs& in, Outputs& out);
  /// The report of a tick that ended in `s` (step() makes it; a tick without a sample, which
  /// republishes the last state flagged, makes it too).
  void report(const EstimatedState& s, StepReport& r) const;
  /// Forgets everything; the next sample initialises.
  void reset();

  [[nodiscard]] const EstimatedState& state() const { return state_; }
  [[nodiscard]] bool initialised() const { return initialised_; }
  [[nodiscard]] const EstimatorConfig& config() const { return config_; }
  /// The contact thresholds and the CoP edge margin, changeable between updates (each update reads
  /// them afresh); the filters' noise models are not.
  [[nodiscard]] EstimatorConfig& tunable_config() { return config_; }
  /// Estimated gyro bias [rad/s], IMU frame.
  [[nodiscard]] const Eigen::Vector3d& gyro_bias() const { return b_; }
  /// Why the last sample was refused ("" when it was not).
  [[nodiscard]] const std::string& implausible_reason() const { return implausible_; }
  /// Standard deviation of the IMU position estimate [m] (largest axis).
  [[nodiscard]] double position_std() const;
  /// The α-β gains in use (α, β).
  [[nodiscard]] const Eigen::Vector2d& joint_filter_gains() const { return ab_; }

 private:
  bool plausible(const SensorSample& s);
  void initialise(const SensorSample& s);
  void update_joints(const SensorSample& s, double dt);
  void leg_kinematics();
  void update_contacts(const SensorSample& s);
  /// Height (world z, from the base) of the lowest corner of sole k.
  [[nodiscard]] double lowest_corner_z(size_t k) const;
  /// The IMU point's velocity (world) if the point r_S of sole k (sole frame) is at rest.
  [[nodiscard]] Eigen::Vector3d imu_velocity_at_rest(size_t k, const Eigen::Vector3d& r_S) const;
  void attitude(const SensorSample& s, double dt);
  void attitude_correct(const Eigen::Vector3d& r, double sigma, const Eigen::Matrix3d& H);
  void position(const SensorSample& s, double dt);
  void position_correct(int rows_at, const Eigen::Vector3d& residual, double sigma, bool velocity);
  void output(const SensorSample& s, double dt);

  const model::RobotSpec* robot_;
  EstimatorConfig config_;
  model::Data data_;
  EstimatedState state_;
  bool initialised_ = false;
  bool anchored_ = false;  // the world frame was placed with a foot in contact
  double t0_ = 0.0, last_time_ = 0.0;
  std::string implausible_;

  // Joints: α-β filter.
  Eigen::VectorXd qj_, qdj_;
  Eigen::Vector2d ab_ = Eigen::Vector2d::Zero();
  double ab_dt_ = 0.0;

  // Leg kinematics with the base at the identity (base frame B), from the filtered joints.
  Eigen::VectorXd q_local_, v_local_;
  Eigen::Vector3d p_BI_ = Eigen::Vector3d::Zero(), v_BI_ = Eigen::Vector3d::Zero();  // IMU point
  Eigen::Matrix3d R_BI_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d w_BI_ = Eigen::Vector3d::Zero();  // IMU body's angular velocity relative to B, in B
  std::array<model::SE3, 2> X_BS_{};                 // soles
  std::array<Eigen::Vector3d, 2> v_BS_{}, w_BS_{};   // their velocity and angular velocity relative to B, in B
  std::array<model::SE3, 2> X_BF_{};                 // force/torque sensor frames
  std::array<Eigen::Vector3d, 2> c_BF_{};            // centre of mass of the part below each sensor
  std::array<double, 2> m_F_{};                      // its mass

  // Contact, and whether a sole in contact is a reliable anchor (flat: CoP inside the sole).
  std::array<bool, 2> contact_{}, anchor_{};
  std::array<bool, 2> turned_{};                     // turned in contact since its CoP was last inside
  std::array<bool, 2> rolling_{};                    // in contact, loaded, no anchor: rolls on an edge or turns
  std::array<Eigen::Vector3d, 2> cop_S_{};           // centre of pressure in the sole frame, inside the sole
  std::array<double, 2> touchdown_time_{-1e9, -1e9};  ///< when each sole last came into contact
  std::array<Eigen::Matrix<double, 6, 1>, 2> wrench_W_{};  // ground on foot, world axes, at the sole centre
  std::array<double, 2> fz_{};

  // Attitude: R_WB, bias (IMU frame), covariance of (δθ (base frame), δb); yaw each anchor holds.
  Eigen::Matrix3d R_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d b_ = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 6, 6> P_att_ = Eigen::Matrix<double, 6, 6>::Zero();
  std::array<Eigen::Matrix3d, 2> R_WS_hold_{};
  // Angular velocity of the base (base frame) and its variance per axis.
  Eigen::Vector3d w_ = Eigen::Vector3d::Zero();
  double P_w_ = 1.0;

  // Position: x = (p_WI, v_WI, p_right, p_left), covariance.
  Eigen::Matrix<double, 12, 1> x_ = Eigen::Matrix<double, 12, 1>::Zero();
  Eigen::Matrix<double, 12, 12> P_ = Eigen::Matrix<double, 12, 12>::Zero();

  // Momentum observer.
  Eigen::Vector3d l_hat_ = Eigen::Vector3d::Zero();
};

/// Registers the live-tunable parameters (the contact hysteresis (contact_on, contact_off), cop_edge_margin and anchor_max_rate) under the keys of the
/// configuration section, with the ranges its loader accepts; the process that runs the component
/// (its own node, or the composed controllers) answers OPERATOR sets with them.
void add_parameters(ParameterSet& params, EstimatorConfig& c);

}  // namespace hpr::estimator
