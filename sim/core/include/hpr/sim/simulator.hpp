#pragma once
/// \file
/// The physics stand-in for the robot (no LCM here; the node does the I/O), over either engine
/// (engine.hpp: Bullet's btMultiBody or MuJoCo, `sim.engine`).
///
/// The whole description (RobotSpec::full_model(): physically consistent inertias) stands on a flat
/// ground; commands and sensors carry the controlled joints only. The held joints
/// are welded at their held positions (SimConfig::held_rigid) or free and held by a stiff joint
/// impedance (or, behind a drive emulator, by what the hal commands them). Every physics sub-step each
/// joint gets the torque of a torque-controlled drive,
///     τ = sat(τ_ff + kp (q_des − q) + kd (q̇_des − q̇)),
/// saturated at the joint's effort limit (modes: run, damp = kd only towards rest, off). Sensors are
/// those of a real robot (joint encoders and torques, a pelvis IMU, ankle force/torque sensors) with
/// optional noise, bias and quantization. Ground truth is computed from the engine's own link states.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "hpr/common/config.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/sim/engine.hpp"

namespace hpr::sim {

struct NoiseConfig {
  bool enabled = false;
  unsigned seed = 1;
  double gyro_noise_density = 0.005;     ///< [rad/s/√Hz]
  double gyro_bias_random_walk = 1e-4;   ///< [rad/s²/√Hz]
  double gyro_bias_initial = 0.005;      ///< [rad/s], per axis, random sign
  double accel_noise_density = 0.05;     ///< [m/s²/√Hz]
  int encoder_bits = 16;                 ///< per revolution; 0 = exact
  double joint_torque_noise = 0.0;       ///< [Nm]
  double ft_force_noise = 1.0;           ///< [N]
  double ft_torque_noise = 0.05;         ///< [Nm]
};

/// Keys of the `sim` section that the sim_bullet process reads for itself (mode, clock, duration,
/// truth, scenario) and SimConfig does not: another process that reads the section (the drive
/// emulator) leaves them alone (Config::known).
inline const std::vector<std::string> kSimProcessKeys = {"mode", "lockstep_timeout", "startup_timeout", "duration",
                                                         "publish_truth", "scenario", "push_input"};

/// MuJoCo's contact and integration settings (`sim.mujoco`).
struct MujocoConfig {
  /// Contact softness: solref (time constant [s], damping ratio). The time constant must be at
  /// least two physics steps.
  double timeconst = 0.005, dampratio = 1.0;
  int condim = 3;             ///< 3: sliding friction; 4: + torsional; 6: + rolling
  bool elliptic_cone = true;  ///< friction cone: elliptic (default) or pyramidal
  bool implicit = false;      ///< integrator: Euler (default) or implicit in the velocity
  double torsional_friction = 0.005, rolling_friction = 0.0001;  ///< [m], with condim 4 and 6
  /// Ratio of the frictional to the normal constraints' impedance (MuJoCo's impratio): above 1,
  /// static friction holds more firmly. With MuJoCo's 1 and the pyramidal cone, the H1-2's loaded
  /// box soles creep 0.10 mm in 10 s of standing; with 10 and the elliptic cone, 0.02 mm.
  double impratio = 10.0;
  /// Iterations of MuJoCo's no-slip post-solver (0: none): removes the creep of soft friction.
  int noslip_iterations = 0;
  /// Where to write the MJCF model the engine builds (empty: nowhere), for MuJoCo's own tools.
  std::string write_model;
};

struct SimConfig {
  EngineKind engine = EngineKind::kBullet;  ///< the physics engine (`sim.engine`: bullet | mujoco)
  MujocoConfig mujoco;
  double dt = 0.001;                ///< control period [s]
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};  ///< [m/s²]
  int substeps = 1;                 ///< physics steps per control period
  int solver_iterations = 20;       ///< the contact solver's iterations (either engine)
  double ground_friction = 0.9;
  /// Contact points a flat polyhedral sole (box, mesh hull) keeps on the ground plane: Bullet adds
  /// one point per step, so after a change of load a sole may stand on one or two corners and turn
  /// about them under a small yaw moment; with multipoint, each step adds the corners found by
  /// rotating the sole slightly when it has fewer than three (btConvexPlaneCollisionAlgorithm's
  /// perturbation), so a flat sole keeps its four corners.
  bool ground_multipoint = true;
  double ground_restitution = 0.0;
  double contact_stiffness = 0.0;   ///< 0: rigid contact (Bullet's default constraint)
  double contact_damping = 0.0;
  double contact_erp = 0.2;         ///< Bullet's error reduction for contacts (penetration recovery)
  double contact_cfm = 0.0;         ///< constraint force mixing (softness) for contacts
  bool joint_limits = true;
  bool feet_only_collisions = true;     ///< only the feet collide with the ground (faster); else every link
  int friction_directions = 2;          ///< 2: isotropic friction; 1: Bullet's single direction
  double joint_friction_coulomb = 0.0;  ///< [Nm]
  double joint_friction_viscous = 0.0;  ///< [Nm s/rad]
  int actuation_delay_ticks = 0;        ///< the drives apply the command of this many ticks ago (0..10)
  double command_timeout = 0.02;        ///< a command older than this [s] is replaced by damping
  double damping_kd = 10.0;             ///< [Nm s/rad] used when damping by itself
  double settle_time = 0.5;             ///< [s] holding the standing posture before tick 0
  double settle_kp = 3000.0, settle_kd = 60.0;
  double held_kp = 3000.0, held_kd = 60.0;  ///< held joints' impedance (capped per joint as hold_gains)
  /// The held joints welded at their held positions (a rigid hand: fewer bodies to integrate, no
  /// drive torque, commands of the held drives accepted and without effect); else held by impedance.
  bool held_rigid = false;
  double fallen_base_height = 0.45;     ///< [m] pelvis below this: fallen
  double fallen_tilt_deg = 45.0;        ///< pelvis tilt above this: fallen
  NoiseConfig noise;
  /// A body of the simulated robot that differs from the description the controllers use (model
  /// uncertainty, for robustness studies): its mass and rotational inertia scaled together
  /// (density), its centre of mass moved in the body frame.
  struct BodyError {
    std::string body;                                      ///< a body of the model (a link, or the link fixed links merge into)
    double mass_scale = 1.0;
    Eigen::Vector3d com_offset = Eigen::Vector3d::Zero();  ///< [m], body frame
  };
  std::vector<BodyError> model_error;

  /// Reads and validates the `sim` section.
  static SimConfig load(const Config& sim_section);
};

using JointCommand = hpr::JointCommand;
using SensorData = hpr::SensorSample;

/// An external force profile on a link.
struct Push {
  /// What a push may ask for, from a scenario file or a PUSH message: each force component within
  /// ±kMaxForce [N], the point within kMaxPoint [m] of the link frame, a duration in
  /// [kMinDuration, kMaxDuration] [s], a start before kMaxStart [s].
  static constexpr double kMaxForce = 1e4, kMaxPoint = 10.0, kMinDuration = 1e-3, kMaxDuration = 60.0, kMaxStart = 1e6;
  enum class Profile { kHalfSine, kRectangle };
  std::int64_t id = 0;
  std::string link;                             ///< URDF link
  Eigen::Vector3d point_L = Eigen::Vector3d::Zero();  ///< application point in the link frame [m]
  Eigen::Vector3d force_W = Eigen::Vector3d::Zero();  ///< peak force [N]
  double start = 0.0;                           ///< simulation time [s]
  double duration = 0.0;                        ///< [s]
  Profile profile = Profile::kHalfSine;
  /// Force at time t (zero outside [start, start + duration)).
  [[nodiscard]] Eigen::Vector3d force_at(double t) const;
  /// Impulse of the whole profile [N s].
  [[nodiscard]] Eigen::Vector3d impulse() const;
};

/// The simulator's ground truth of a step (SIM_TRUTH).
using TruthData = SimTruth;

class Simulator {
 public:
  /// Simulates `robot.description`: the controlled joints (those of `robot.model`, the only ones
  /// commands and sensors carry) are driven by the commands, the held joints (`robot.held`) welded or
  /// driven by a stiff joint impedance at their held positions (`config.held_rigid`). The physics
  /// engine is `make_engine`'s (sim::make_engine of hpr/sim/engines.hpp: the one `config.engine`
  /// names).
  Simulator(const model::RobotSpec& robot, SimConfig config, const EngineFactory& make_engine);
  ~Simulator();
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  /// Places the standing posture with the soles on the ground, settles, and starts at tick 0.
  void reset();
  /// Places an arbitrary state (tests); no settling.
  void set_state(const Eigen::VectorXd& q, const Eigen::VectorXd& v);
  /// Takes a joint command after validating it; returns false (and counts it) when it is rejected
  /// (wrong size, non-finite value, negative gains), keeping the last valid command.
  bool set_command(const JointCommand& command, std::string* why = nullptr);
  /// Drives the held joints (RobotSpec::model.held_joint_name order) with `command` from now on,
  /// instead of the simulator's own hold: a drive emulator passes on what the hal sends them.
  /// Returns false (and keeps the previous) when it is malformed. Welded held joints ignore it.
  bool set_held_command(const JointCommand& command, std::string* why = nullptr);
  /// Schedules a push (start time in simulation time; negative: now).
  void add_push(Push push);
  /// Advances one control period.
  void step();

  /// The simulator as a component of the control graph (the robot's side of tick k → k+1).
  struct Inputs {
    const JointCommand* command = nullptr;  ///< JOINT_COMMAND answering tick k; null keeps the last one
  };
  struct Outputs {
    const SensorData* sensors = nullptr;  ///< ROBOT_SENSORS of tick k+1 (points into the simulator)
    const TruthData* truth = nullptr;     ///< SIM_TRUTH of tick k+1
    bool command_taken = true;            ///< false: the command was refused (counted), the last valid one acted
  };
  /// Takes `in.command` as set_command() does, advances one control period and points `out` at the
  /// new sensors and truth.
  void step(const Inputs& in, Outputs& out) {
    out.command_taken = in.command == nullptr || set_command(*in.command);
    step();
    out.sensors = &sensors_;
    out.truth = &truth_;
  }

  [[nodiscard]] const SensorData& sensors() const { return sensors_; }
  [[nodiscard]] const TruthData& truth() const { return truth_; }
  [[nodiscard]] double time() const { return time_; }
  [[nodiscard]] std::int64_t tick() const { return tick_; }
  [[nodiscard]] std::int64_t rejected_commands() const { return rejected_; }
  [[nodiscard]] bool command_stale() const { return stale_; }
  [[nodiscard]] const SimConfig& config() const { return config_; }
  [[nodiscard]] const model::RobotSpec& robot() const { return *robot_; }
  /// The engine stepping the simulated model.
  [[nodiscard]] const Engine& engine() const { return *engine_; }
  /// The simulated model: every joint of the description, physically consistent inertias.
  [[nodiscard]] const model::Model& simulated_model() const { return full_; }
  /// Index in simulated_model() of each controlled joint.
  [[nodiscard]] const std::vector<int>& simulated_joint() const { return joint_of_; }
  /// Applied joint torques of the last sub-step (after saturation).
  [[nodiscard]] const Eigen::VectorXd& applied_torque() const { return applied_; }

 private:
  void apply_actuation();
  void physics_substep(double h);
  void refresh_motion();
  void compute_truth();
  void compute_sensors();
  void apply_hold(JointCommand::Mode mode);
  /// Drives joint j (of the simulated model) with τ saturated at ±lim, plus `friction`: with an
  /// engine that integrates joint damping implicitly (Engine::integrates_damping) and τ within its
  /// limit, τ's −kd q̇ part goes to the engine as damping. Returns the applied (saturated) τ.
  double drive(int j, double tau, double kd, double qd, double lim, double friction = 0.0);
  void expand_state(const Eigen::VectorXd& q, const Eigen::VectorXd& v);
  Eigen::VectorXd settle_torque() const;

  const model::RobotSpec* robot_;
  SimConfig config_;
  model::Model full_;                 ///< what Bullet integrates (robot_->full_model(held_rigid))
  std::vector<int> joint_of_;         ///< full_ joint of each controlled joint
  std::vector<int> held_joint_;       ///< full_ joints held by impedance (none when they are rigid)
  Eigen::VectorXd held_q_, held_kp_, held_kd_, held_tau_;
  JointCommand held_command_;         ///< the hal's command of the held joints (emulator)
  bool held_external_ = false;
  std::array<int, 2> sole_frame_{}, ft_frame_{};  ///< in full_
  int imu_frame_ = -1;                ///< in full_
  Eigen::VectorXd q_full_, v_full_;   ///< get_state workspace
  std::array<int, 2> foot_body_{};    ///< in full_
  std::unique_ptr<Engine> engine_;
  std::array<model::Vector6d, 2> contact_impulse_O_{};  ///< Σ (J, p × J) on each foot over the control period, world origin
  std::vector<BodyMotion> motion_;    ///< the engine's body motions at the current step (refresh_motion)
  SensorData sensors_;
  TruthData truth_;
  std::vector<JointCommand> delay_line_;  ///< the last actuation_delay_ticks + 1 commands, a ring
  std::size_t delay_head_ = 0;            ///< the newest (the command the drives were last sent)
  bool have_command_ = false, stale_ = false;
  double command_time_ = -1e9;
  std::int64_t rejected_ = 0;
  double time_ = 0.0;
  std::int64_t tick_ = 0;
  Eigen::VectorXd applied_, settle_kp_, settle_kd_;
  std::vector<Push> pushes_;
  std::mt19937_64 rng_;
  Eigen::Vector3d gyro_bias_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_imu_prev_ = Eigen::Vector3d::Zero();
  bool have_v_imu_prev_ = false;
  Eigen::VectorXd q_meas_prev_;
  std::array<Eigen::Matrix<double, 6, 1>, 2> foot_momentum_prev_{};
  bool have_foot_momentum_prev_ = false;
};

/// Joint impedance gains (kp, kd) that hold a posture stably with torques evaluated every `dt`: the
/// requested gains for the legs (their inertia in stance is the whole robot's), and for every other
/// joint at most kp ≤ 0.2 I_j / dt² and kd ≤ 0.5 I_j / dt with I_j = 1 / (M⁻¹)_jj the inertia the
/// joint's torque meets at q, so that an explicitly evaluated spring-damper on a light distal link
/// stays stable.
void hold_gains(const model::RobotSpec& robot, const Eigen::VectorXd& q, double kp, double kd, double dt,
                Eigen::VectorXd& kp_out, Eigen::VectorXd& kd_out);

/// Parses a push scenario file: a YAML list under `pushes:` of {link, point, force, start, duration,
/// profile}. Errors name the file and key.
std::vector<Push> load_scenario(const std::string& path);

}  // namespace hpr::sim
