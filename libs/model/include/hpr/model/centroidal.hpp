#pragma once
/// \file
/// The paper's coordinates (Schuller et al., section II-A).
///
/// Generalized velocity ν = (ν_c, q̇) with ν_c = (ẋ_c, ω_b): CoM velocity and base angular velocity,
/// both in world axes. The model's v relates to it by v = Ĵ ν with
///     v_B = R_bᵀ (ẋ_c − ω_b × (x_c − p_b) − J_cq q̇),   ω_B = R_bᵀ ω_b,
/// J_cq being the CoM Jacobian of the joints with the base fixed. In these coordinates the inertia
/// matrix of (1) is blkdiag(m E, [[I_c, A_q], [A_qᵀ, M_qq − m J_cqᵀ J_cq]]) (so its CoM block is m E and
/// decoupled, (20)), gravity acts on the CoM rows only, and the rotational CMM (3) is A = [0, I_c, A_q].
///
/// Task coordinates (2): ẋ = (ν_c, ν_r, ν_l, q̇_f) = J ν with foot twists ν_i = Ad_i ν_c + J'_i q̇
/// (world axes at the sole centre), Ad_i = [[E, −[x_i − x_c]×], [0, E]], J'_i = [[J_i,lin − J_cq],
/// [J_i,ang]]. Ā = A J⁻¹ (3).

#include <Eigen/LU>

#include "hpr/model/algorithms.hpp"
#include "hpr/model/robot.hpp"

namespace hpr::model {

/// v = Ĵ ν (requires data.com, data.Jcom and data.oMi[0] of the current q: after ccrba or compute_all_terms).
void centroidal_to_model_velocity(const Model& model, const Data& data, const ConstVector& nu, Eigen::Ref<Eigen::VectorXd> v);
/// ν = Ĵ⁻¹ v (also needs data.Jcom).
void model_to_centroidal_velocity(const Model& model, const Data& data, const ConstVector& v, Eigen::Ref<Eigen::VectorXd> nu);
/// The matrix Ĵ (nv x nv), for tests and tools.
void centroidal_velocity_map(const Model& model, const Data& data, Eigen::MatrixXd& Jhat);

/// M of (1) in the paper's coordinates, from data after compute_all_terms (or crba + ccrba).
void centroidal_mass_matrix(const Model& model, const Data& data, Eigen::MatrixXd& Mbar);

/// y = M̄ ν̇_r + C̄ ν_r in the paper's coordinates at the state (q, v), with C̄ = ĴᵀCĴ + ĴᵀMĴ̇ and C the
/// Christoffel-consistent factorisation of passivity_rnea, so that dM̄/dt − 2C̄ is skew-symmetric.
/// Gravity is not included (in these coordinates it is (−w_g, 0)). O(n); writes data.y.
const Eigen::VectorXd& centroidal_inverse_dynamics(const Model& model, Data& data, const ConstVector& q,
                                                   const ConstVector& v, const ConstVector& nu_r,
                                                   const ConstVector& nudot_r);
/// The same on `data` whose kinematics are already those of (q, v) (compute_all_terms, as the wbc
/// runs every tick): the kinematics once per tick instead of three times.
const Eigen::VectorXd& centroidal_inverse_dynamics_from_kinematics(const Model& model, Data& data, const ConstVector& v,
                                                                   const ConstVector& nu_r, const ConstVector& nudot_r);

/// The task Jacobian (2) of a biped and what is derived from it: A (3), Ad, J', J⁻¹ and Ā = A J⁻¹.
/// The same J serves double and single support (the swing foot's coordinates are its Cartesian pose).
class TaskSpace {
 public:
  explicit TaskSpace(const RobotSpec& robot);

  /// From data after compute_all_terms (which includes frame placements). Returns false when the
  /// legs' block J'_L is singular (reciprocal condition estimate below `rcond_min`, e.g. a knee
  /// stretched): then singular() is true and solve(), Abar() keep their last valid values.
  bool update(const Model& model, Data& data, double rcond_min = 1e-5);

  [[nodiscard]] bool singular() const { return singular_; }
  [[nodiscard]] double rcond() const { return rcond_; }
  [[nodiscard]] int nbar() const { return nbar_; }
  /// Rotational CMM A (3 x n̄) over ν = (ν_c, q̇).
  [[nodiscard]] const Matrix3Xd& A() const { return A_; }
  /// Ā = A J⁻¹ (3 x n̄) over ẋ = (ν_c, ν_r, ν_l, q̇_f).
  [[nodiscard]] const Matrix3Xd& Abar() const { return Abar_; }
  /// Stacked adjoints (12 x 6) and foot Jacobians J' (12 x n).
  [[nodiscard]] const Eigen::Matrix<double, 12, 6>& Ad() const { return Ad_; }
  [[nodiscard]] const Eigen::Matrix<double, 12, Eigen::Dynamic>& Jprime() const { return Jp_; }
  /// Sole placements and the CoM used in the last update.
  [[nodiscard]] const SE3& sole(int foot) const { return X_WS_[static_cast<size_t>(foot)]; }
  [[nodiscard]] const Vector3d& com() const { return com_; }

  /// ẋ = J ν.
  void apply(const ConstVector& nu, Eigen::Ref<Eigen::VectorXd> xdot) const;
  /// ν = J⁻¹ ẋ.
  void solve(const ConstVector& xdot, Eigen::Ref<Eigen::VectorXd> nu) const;
  /// Jᵀ w for w = (w_c, w_r, w_l, τ_f) in task coordinates -> generalized forces over ν.
  void apply_transpose(const ConstVector& w, Eigen::Ref<Eigen::VectorXd> out) const;
  /// The explicit matrices (for tests and tools).
  void jacobian(Eigen::MatrixXd& J) const;
  void jacobian_inverse(Eigen::MatrixXd& Jinv) const;

  /// Index of task coordinate blocks in ẋ.
  static constexpr int kCom = 0, kBaseRot = 3, kRightFoot = 6, kLeftFoot = 12, kFree = 18;

 private:
  const RobotSpec* robot_;
  int n_ = 0, nbar_ = 0;
  std::vector<int> legs_, free_;
  Matrix6Xd Jf_;                                  // foot Jacobian workspace (6 x nv)
  Matrix3Xd A_, Abar_;
  Eigen::Matrix<double, 12, 6> Ad_;
  Eigen::Matrix<double, 12, Eigen::Dynamic> Jp_;
  Eigen::Matrix<double, 12, 12> JL_;
  Eigen::Matrix<double, 12, Eigen::Dynamic> JF_;
  Eigen::PartialPivLU<Eigen::Matrix<double, 12, 12>> lu_;
  std::array<SE3, 2> X_WS_;
  Vector3d com_ = Vector3d::Zero();
  double rcond_ = 0.0;
  bool singular_ = true;
  bool valid_ = false;
};

}  // namespace hpr::model
