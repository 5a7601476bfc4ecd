#pragma once
/// \file
/// A Bullet btMultiBody built from the shared robot model, and conversions between its state and the
/// model's coordinates.
///
/// Bullet places every link frame at the link's centre of mass along its principal axes, so each
/// body's inertia is diagonalised here and the Bullet link frame L_i sits at X_BL (centre of mass,
/// principal axes) in the model's body frame B_i. Joint angles are the same numbers in both.

#include <BulletDynamics/Featherstone/btMultiBody.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "hpr/model/model.hpp"

namespace hpr::sim {

struct BulletBody {
  model::SE3 X_BL;           ///< Bullet link frame (CoM, principal axes) in the model body frame
  Eigen::Vector3d inertia;   ///< principal moments [kg m^2]
};

/// Owns a btMultiBody with the model's tree. Bullet link i is model body i + 1; the base is body 0.
class MultiBodyRobot {
 public:
  /// Builds the tree (masses, inertias, joint axes and placements). Collision shapes and limits are
  /// added by the simulator.
  explicit MultiBodyRobot(const model::Model& model);
  ~MultiBodyRobot();
  MultiBodyRobot(const MultiBodyRobot&) = delete;
  MultiBodyRobot& operator=(const MultiBodyRobot&) = delete;

  [[nodiscard]] btMultiBody* multibody() { return mb_.get(); }
  [[nodiscard]] const btMultiBody* multibody() const { return mb_.get(); }
  [[nodiscard]] const model::Model& model() const { return *model_; }
  [[nodiscard]] const std::vector<BulletBody>& bodies() const { return bodies_; }
  /// Releases ownership (a dynamics world takes it over).
  btMultiBody* release();

  /// Sets Bullet's positions and velocities from the model's q and v.
  void set_state(const Eigen::VectorXd& q, const Eigen::VectorXd& v);
  /// Reads Bullet's state as the model's q and v.
  void get_state(Eigen::VectorXd& q, Eigen::VectorXd& v) const;

  /// Converts the model's generalized force τ (base part: wrench in the base frame at its origin)
  /// into Bullet's applied base force and torque (world, at the base CoM) and joint torques, adding
  /// them to what is already applied.
  void add_generalized_force(const Eigen::VectorXd& tau);

  /// Converts accelerations of Bullet's state (d/dt of the world CoM velocity and world angular
  /// velocity of the base, joint accelerations) to the model's v̇, given the model state v.
  Eigen::VectorXd to_model_acceleration(const Eigen::VectorXd& bullet_acc, const Eigen::VectorXd& v) const;

  /// World placement of model body `body`'s Bullet link frame X_WL (its centre of mass, principal
  /// axes), from the cached link transforms.
  [[nodiscard]] model::SE3 link_frame(int body) const;
  /// World placement of model body `body` as the model's body placement X_WB = X_WL X_BL⁻¹.
  [[nodiscard]] model::SE3 body_placement(int body) const;

 private:
  const model::Model* model_;
  std::vector<BulletBody> bodies_;
  std::unique_ptr<btMultiBody> mb_;
  bool owned_ = true;
};

inline btVector3 to_bt(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
inline Eigen::Vector3d from_bt(const btVector3& v) { return {v.x(), v.y(), v.z()}; }
btQuaternion to_bt_quaternion(const Eigen::Matrix3d& R);
Eigen::Matrix3d from_bt(const btQuaternion& q);

}  // namespace hpr::sim
