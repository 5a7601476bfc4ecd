#pragma once
/// \file
/// The physics engine under the simulator: what the simulator asks of Bullet or MuJoCo.
///
/// The simulator (hpr::sim::Simulator) owns what does not depend on the engine: the drive model
/// and its command checks, the actuation delay, the held joints, the pushes' profiles, the sensors
/// and their noise, the ground truth. An Engine integrates the simulated robot (the full model, body
/// and joint indices of model::Model) standing on the plane z = 0, and reports the state in the
/// engine's own terms (its link frames, velocities and mass properties), so the truth and the
/// sensors are computed from what the engine integrates, not from our own kinematics.

#include <Eigen/Core>
#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hpr/model/model.hpp"
#include "hpr/model/robot.hpp"

namespace hpr::sim {

struct SimConfig;

/// A body's mass properties and motion as the engine holds them (its inertial frame I: centre of
/// mass, principal axes).
struct BodyMotion {
  double m = 0.0;                                        ///< mass [kg]
  Eigen::Vector3d c_W = Eigen::Vector3d::Zero();         ///< centre of mass [m]
  Eigen::Matrix3d R_WI = Eigen::Matrix3d::Identity();    ///< principal axes
  Eigen::Vector3d I_principal = Eigen::Vector3d::Zero(); ///< principal moments [kg m²]
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();         ///< velocity of the centre of mass [m/s]
  Eigen::Vector3d omega_W = Eigen::Vector3d::Zero();     ///< angular velocity [rad/s]
};

class Engine {
 public:
  virtual ~Engine() = default;
  /// "bullet" or "mujoco".
  [[nodiscard]] virtual const char* name() const = 0;
  /// Places the robot at (q, v), the full model's coordinates.
  virtual void set_state(const Eigen::VectorXd& q, const Eigen::VectorXd& v) = 0;
  /// Reads the state as the full model's (q, v).
  virtual void get_state(Eigen::VectorXd& q, Eigen::VectorXd& v) const = 0;
  [[nodiscard]] virtual double joint_position(int j) const = 0;
  [[nodiscard]] virtual double joint_velocity(int j) const = 0;
  /// Adds a torque [Nm] (force [N] on a prismatic joint) on joint j for the next step.
  virtual void add_joint_torque(int j, double tau) = 0;
  /// True when the engine integrates joint damping implicitly (add_joint_damping): a drive's
  /// −kd q̇ is then integrated stably whatever the joint's inertia and the contact's stiffness.
  [[nodiscard]] virtual bool integrates_damping() const { return false; }
  /// Adds a joint damping kd [Nm s/rad] on joint j for the next step (integrates_damping() only).
  virtual void add_joint_damping(int j, double kd) { (void)j, (void)kd; }
  /// Adds the force F_W [N] at the world point p_W [m] on body b for the next step.
  virtual void add_force(int b, const Eigen::Vector3d& F_W, const Eigen::Vector3d& p_W) = 0;
  /// Advances h [s] with what was added (then cleared), and adds the ground's impulse on each foot
  /// over the step, (J, p × J) about the world origin [N s, N m s], to `impulse_O`.
  virtual void step(double h, std::array<model::Vector6d, 2>& impulse_O) = 0;
  /// World placement of body b's frame (the model's body frame).
  [[nodiscard]] virtual model::SE3 body_placement(int b) const = 0;
  /// Every body's mass properties and motion, indexed as the model's bodies (no allocation once
  /// `out` has the size).
  virtual void body_motions(std::vector<BodyMotion>& out) const = 0;
};

/// A collision shape of a body, engine-neutral: both engines build theirs from these.
struct CollisionShape {
  enum class Type { kBox, kCylinder, kSphere, kHull };
  Type type = Type::kBox;
  model::SE3 X_BG;                                  ///< the shape's centre in the model's body frame
  Eigen::Vector3d size = Eigen::Vector3d::Zero();   ///< box: half extents; cylinder: (radius, half length, 0), along z; sphere: (radius, 0, 0)
  std::vector<Eigen::Vector3d> points;              ///< hull: its points in the shape's frame
};

/// The shapes of every body of `m` that may touch the ground (the feet only, or every body when
/// `config.feet_only_collisions` is off; empty for the others): the URDF links' collision
/// geometries merged per body, a mesh as its bounding box or its hull (robot.mesh_collision), and
/// a foot without collision geometry as its configured sole, a box 2 cm thick. Throws ModelError
/// naming the link when a mesh does not load.
std::vector<std::vector<CollisionShape>> collision_shapes(const model::RobotSpec& robot, const model::Model& m,
                                                          const SimConfig& config, const std::array<int, 2>& foot_body);

/// The engines this build has.
enum class EngineKind { kBullet, kMujoco };
[[nodiscard]] const char* to_string(EngineKind kind);

/// The collision shapes of every body of a model (collision_shapes()).
using Shapes = std::vector<std::vector<CollisionShape>>;

/// What builds the engine of a Simulator: the engine `config.engine` names for the simulated model
/// `m` of `robot`, with the two feet at bodies `foot_body` of `m` (their contact is what step()
/// reports). The stack's is sim::make_engine (hpr/sim/engines.hpp), which knows both engines; a
/// test may give its own.
using EngineFactory = std::function<std::unique_ptr<Engine>(const model::RobotSpec& robot, const model::Model& m,
                                                            const SimConfig& config, const std::array<int, 2>& foot_body)>;

}  // namespace hpr::sim
