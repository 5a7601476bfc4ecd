#pragma once
/// \file
/// Rigid-body algorithms on a Model, each a free function named after the algorithm, writing into
/// a Data and allocating nothing. Quantities are computed in the world frame W with spatial vectors
/// at the world origin (Featherstone's algorithms are valid in any fixed frame), which makes the
/// composite-inertia recursions plain sums.

#include <Eigen/Core>

#include "hpr/model/model.hpp"

namespace hpr::model {

using ConstVector = Eigen::Ref<const Eigen::VectorXd>;

enum class ReferenceFrame {
  kWorld,              ///< spatial twist in W at the world origin
  kLocal,              ///< twist in the frame's own axes at its origin
  kLocalWorldAligned,  ///< world axes, at the frame's origin (linear part = velocity of that point)
};

/// R_WB of the base from q (quaternion stored (x, y, z, w) at q[3..6]).
Eigen::Quaterniond base_quaternion(const ConstVector& q);

/// Body placements oMi, joint motion subspaces S (in W) and body inertias in W.
void forward_kinematics(const Model& model, Data& data, const ConstVector& q);
/// Also body twists (in W).
void forward_kinematics(const Model& model, Data& data, const ConstVector& q, const ConstVector& v);
/// Frame placements oMf from oMi (after forward_kinematics): all frames, or one.
void update_frame_placements(const Model& model, Data& data);
const SE3& update_frame_placement(const Model& model, Data& data, int frame);

/// Joint-space inertia M(q) by the composite rigid body algorithm. Fills data.M (and data.Yc, data.F).
const Eigen::MatrixXd& crba(const Model& model, Data& data, const ConstVector& q);
/// Inverse dynamics τ = M(q) a + C(q, v) v + g(q) by the recursive Newton-Euler algorithm.
const Eigen::VectorXd& rnea(const Model& model, Data& data, const ConstVector& q, const ConstVector& v,
                            const ConstVector& a);
/// C(q, v) v + g(q).
const Eigen::VectorXd& nonlinear_effects(const Model& model, Data& data, const ConstVector& q, const ConstVector& v);
/// g(q).
const Eigen::VectorXd& generalized_gravity(const Model& model, Data& data, const ConstVector& q);
/// τ = M(q) a_r + C(q, v) v_r (+ g(q) if `with_gravity`) with the Christoffel-consistent factorisation
/// C = Σ_i J_iᵀ (I_i J̇_i + B_i(v_i) J_i), B(v) = ½[(v×*) I − I (v×) + (I v)×̄*], for which Ṁ − 2C is
/// skew-symmetric (the Slotine-Li form of passivity-based control) and whose rows for the total
/// momentum vanish, so that in the paper's coordinates the CoM rows of C̄ are zero (20).
/// With v_r = v and a_r = a it equals rnea.
const Eigen::VectorXd& passivity_rnea(const Model& model, Data& data, const ConstVector& q, const ConstVector& v,
                                      const ConstVector& v_r, const ConstVector& a_r, bool with_gravity = false);
/// The same on `data` whose kinematics are already those of (q, v) (forward_kinematics with v, or
/// compute_all_terms): no second pass over the placements.
const Eigen::VectorXd& passivity_rnea_from_kinematics(const Model& model, Data& data, const ConstVector& v_r,
                                                      const ConstVector& a_r, bool with_gravity = false);
/// The matrix C(q, v) of passivity_rnea, column by column (O(n^2) RNEA calls; for tests and tools).
void coriolis_matrix(const Model& model, Data& data, const ConstVector& q, const ConstVector& v, Eigen::MatrixXd& C);

/// Centre of mass x_c (and ẋ_c with v).
const Vector3d& center_of_mass(const Model& model, Data& data, const ConstVector& q);
const Vector3d& center_of_mass(const Model& model, Data& data, const ConstVector& q, const ConstVector& v);
/// Centroidal momentum matrix A_G (6 x nv, world axes about the CoM, linear rows first), h_G = A_G v,
/// the CoM, its velocity and Jacobian, and the composite rotational inertia I_c.
const Matrix6Xd& ccrba(const Model& model, Data& data, const ConstVector& q, const ConstVector& v);
/// Ȧ_G v: the centroidal momentum rate at zero acceleration (needed by a momentum observer).
const Vector6d& centroidal_momentum_bias(const Model& model, Data& data, const ConstVector& q, const ConstVector& v);

/// Everything a controller needs per tick, sharing the passes: kinematics with velocities, M,
/// C(q, v) v + g, g, A_G, h_G, Ȧ_G v, CoM, its velocity and Jacobian, I_c. Frame placements are not
/// updated (call update_frame_placements or update_frame_placement for the frames you need).
void compute_all_terms(const Model& model, Data& data, const ConstVector& q, const ConstVector& v);

/// Jacobian of frame `frame` (after forward_kinematics; the frame placement is taken from oMi); J is
/// 6 x nv (linear rows first). Columns of joints that do not move the frame are zero.
void frame_jacobian(const Model& model, const Data& data, int frame, ReferenceFrame rf, Eigen::Ref<Matrix6Xd> J);
/// The same from q alone (Pinocchio's computeFrameJacobian): the placements of the frame's support
/// chain only (oMi and S of the bodies from the root to the frame's body; the rest of `data` is left
/// as it was), then frame_jacobian. For a foot, about a quarter of the work of forward_kinematics.
void compute_frame_jacobian(const Model& model, Data& data, const ConstVector& q, int frame, ReferenceFrame rf,
                            Eigen::Ref<Matrix6Xd> J);
/// Twist of frame `frame` (after forward_kinematics with v).
Vector6d frame_velocity(const Model& model, const Data& data, int frame, ReferenceFrame rf);
/// Classical acceleration of the frame origin and angular acceleration at zero joint acceleration
/// (J̇ v in kLocalWorldAligned), after a call that computed data.vel.
Vector6d frame_jacobian_time_variation_times_v(const Model& model, const Data& data, int frame);

/// Forward dynamics a = M⁻¹ (τ − C v − g) (dense; for tests and tools).
Eigen::VectorXd forward_dynamics(const Model& model, Data& data, const ConstVector& q, const ConstVector& v,
                                 const ConstVector& tau);

/// q ⊕ v dt: the base moves along the screw of its (local) twist, joints add.
Eigen::VectorXd integrate(const Model& model, const ConstVector& q, const ConstVector& v_dt);
/// The velocity v such that integrate(q0, v) = q1.
Eigen::VectorXd difference(const Model& model, const ConstVector& q0, const ConstVector& q1);

}  // namespace hpr::model
