#include "hpr/model/centroidal.hpp"

#include "index.hpp"

namespace hpr::model {
using detail::u;

void centroidal_to_model_velocity(const Model& model, const Data& data, const ConstVector& nu,
                                  Eigen::Ref<Eigen::VectorXd> v) {
  const Matrix3d& R = data.oMi[0].R;
  const Vector3d r = data.com - data.oMi[0].p;
  const Vector3d w = nu.segment<3>(3);
  const Vector3d xdot_joints = data.Jcom.rightCols(model.nj) * nu.tail(model.nj);
  v.head<3>() = R.transpose() * (nu.head<3>() - w.cross(r) - xdot_joints);
  v.segment<3>(3) = R.transpose() * w;
  v.tail(model.nj) = nu.tail(model.nj);
}

void model_to_centroidal_velocity(const Model& model, const Data& data, const ConstVector& v,
                                  Eigen::Ref<Eigen::VectorXd> nu) {
  nu.head<3>() = data.Jcom * v;
  nu.segment<3>(3) = data.oMi[0].R * v.segment<3>(3);
  nu.tail(model.nj) = v.tail(model.nj);
}

void centroidal_velocity_map(const Model& model, const Data& data, Eigen::MatrixXd& Jhat) {
  Jhat.setZero(model.nv, model.nv);
  const Matrix3d Rt = data.oMi[0].R.transpose();
  const Vector3d r = data.com - data.oMi[0].p;
  Jhat.topLeftCorner<3, 3>() = Rt;
  Jhat.block<3, 3>(0, 3) = Rt * skew(r);
  Jhat.topRightCorner(3, model.nj) = -Rt * data.Jcom.rightCols(model.nj);
  Jhat.block<3, 3>(3, 3) = Rt;
  Jhat.bottomRightCorner(model.nj, model.nj).setIdentity();
}

void centroidal_mass_matrix(const Model& model, const Data& data, Eigen::MatrixXd& Mbar) {
  const int n = model.nj;
  Mbar.setZero(model.nv, model.nv);
  Mbar.topLeftCorner<3, 3>() = data.mass * Matrix3d::Identity();
  Mbar.block<3, 3>(3, 3) = data.Ic;
  Mbar.block(3, 6, 3, n) = data.Ag.bottomRows<3>().rightCols(n);
  Mbar.block(6, 3, n, 3) = Mbar.block(3, 6, 3, n).transpose();
  const auto Jcq = data.Jcom.rightCols(n);
  Mbar.bottomRightCorner(n, n) = data.M.bottomRightCorner(n, n);
  Mbar.bottomRightCorner(n, n).noalias() -= data.mass * Jcq.transpose() * Jcq;
}

const Eigen::VectorXd& centroidal_inverse_dynamics(const Model& model, Data& data, const ConstVector& q,
                                                   const ConstVector& v, const ConstVector& nu_r,
                                                   const ConstVector& nudot_r) {
  forward_kinematics(model, data, q, v);
  return centroidal_inverse_dynamics_from_kinematics(model, data, v, nu_r, nudot_r);
}

const Eigen::VectorXd& centroidal_inverse_dynamics_from_kinematics(const Model& model, Data& data, const ConstVector& v,
                                                                   const ConstVector& nu_r, const ConstVector& nudot_r) {
  const int n = model.nj;
  // CoM, its velocity, J_cq q̇_r, J_cq q̈_r and d/dt(J_cq) q̇_r from one sweep over the bodies:
  //   m J_cq q̇ = Σ_i (I_i w_i)_lin with w_i the twist of body i for joint rates q̇ and the base fixed.
  Vector3d h = Vector3d::Zero(), p_lin = Vector3d::Zero(), P = Vector3d::Zero(), Pa = Vector3d::Zero(),
           Pdot = Vector3d::Zero();
  std::vector<Vector6d>& w = data.acc;   // w_i for q̇_r
  std::vector<Vector6d>& wd = data.f;    // ẇ_i along the actual motion, for q̇_r
  std::vector<Vector6d>& wa = data.F;    // w_i for q̈_r
  w[0].setZero();
  wd[0].setZero();
  wa[0].setZero();
  for (int i = 1; i < model.nb; ++i) {
    const int p = model.parent[u(i)];
    const Vector6d& S = data.S[u(i)];
    w[u(i)] = w[u(p)] + S * nu_r(5 + i);
    wa[u(i)] = wa[u(p)] + S * nudot_r(5 + i);
    wd[u(i)] = wd[u(p)] + cross_motion(data.vel[u(i)], S) * nu_r(5 + i);
  }
  for (int i = 0; i < model.nb; ++i) {
    const Inertia& I = data.Iw[u(i)];
    const Vector6d& vi = data.vel[u(i)];
    h += I.h;
    p_lin += (I * vi).head<3>();
    const Vector6d Iw = I * w[u(i)];
    P += Iw.head<3>();
    Pa += (I * wa[u(i)]).head<3>();
    Pdot += (cross_force(vi, Iw) - I * cross_motion(vi, w[u(i)]) + I * wd[u(i)]).head<3>();
  }
  const double m = model.mass;
  const Vector3d c = h / m, cdot = p_lin / m;
  const Vector3d Jcq_qd = P / m, Jcq_qdd = Pa / m, dJcq_qd = Pdot / m;
  const Matrix3d& R = data.oMi[0].R;
  const Vector3d& pb = data.oMi[0].p;
  const Vector3d r = c - pb;
  const Vector3d pb_dot = R * v.head<3>();
  const Vector3d rdot = cdot - pb_dot;
  const Vector3d wB = v.segment<3>(3);  // actual base angular velocity, base frame

  // v_r = Ĵ ν_r and a_r = Ĵ ν̇_r + Ĵ̇ ν_r.
  const Vector3d wr = nu_r.segment<3>(3), wrd = nudot_r.segment<3>(3);
  const Vector3d u_r = nu_r.head<3>() - wr.cross(r) - Jcq_qd;
  const Vector3d u_a = nudot_r.head<3>() - wrd.cross(r) - Jcq_qdd;
  data.v_r.head<3>() = R.transpose() * u_r;
  data.v_r.segment<3>(3) = R.transpose() * wr;
  data.v_r.tail(n) = nu_r.tail(n);
  data.a_r.head<3>() = R.transpose() * u_a - wB.cross(R.transpose() * u_r) +
                       R.transpose() * (-wr.cross(rdot) - dJcq_qd);
  data.a_r.segment<3>(3) = R.transpose() * wrd - wB.cross(R.transpose() * wr);
  data.a_r.tail(n) = nudot_r.tail(n);

  const Eigen::VectorXd& tau = passivity_rnea_from_kinematics(model, data, data.v_r, data.a_r, false);
  // y = Ĵᵀ τ.
  const Vector3d f_W = R * tau.head<3>();
  data.y.head<3>() = f_W;
  data.y.segment<3>(3) = R * tau.segment<3>(3) - r.cross(f_W);
  // J_cq = (1/m) Σ_j F_j,lin per joint: recompute the composite momenta columns for the transpose.
  for (int i = 0; i < model.nb; ++i) data.Yc[u(i)] = data.Iw[u(i)];
  for (int i = model.nb - 1; i > 0; --i) data.Yc[u(model.parent[u(i)])] += data.Yc[u(i)];
  for (int i = 1; i < model.nb; ++i) {
    const Vector3d Jc_col = (data.Yc[u(i)] * data.S[u(i)]).head<3>() / m;
    data.y(5 + i) = tau(5 + i) - Jc_col.dot(f_W);
  }
  return data.y;
}

TaskSpace::TaskSpace(const RobotSpec& robot) : robot_(&robot) {
  const Model& m = robot.model;
  n_ = m.nj;
  nbar_ = m.nv;
  legs_ = robot.leg_joints;
  free_ = robot.free_joints;
  Jf_ = Matrix6Xd::Zero(6, m.nv);
  A_ = Matrix3Xd::Zero(3, nbar_);
  Abar_ = Matrix3Xd::Zero(3, nbar_);
  Ad_.setZero();
  Jp_ = Eigen::Matrix<double, 12, Eigen::Dynamic>::Zero(12, n_);
  JL_.setZero();
  JF_ = Eigen::Matrix<double, 12, Eigen::Dynamic>::Zero(12, static_cast<int>(free_.size()));
}

bool TaskSpace::update(const Model& model, Data& data, double rcond_min) {
  const int n = n_;
  com_ = data.com;
  const auto Jcq = data.Jcom.rightCols(n);
  for (int k = 0; k < 2; ++k) {
    const int frame = robot_->feet[u(k)].sole_frame;
    X_WS_[u(k)] = update_frame_placement(model, data, frame);
    frame_jacobian(model, data, frame, ReferenceFrame::kLocalWorldAligned, Jf_);
    Jp_.block(6 * k, 0, 3, n) = Jf_.topRightCorner(3, n) - Jcq;
    Jp_.block(6 * k + 3, 0, 3, n) = Jf_.bottomRightCorner(3, n);
    Ad_.block<6, 6>(6 * k, 0).setIdentity();
    Ad_.block<3, 3>(6 * k, 3) = -skew(X_WS_[u(k)].p - com_);
  }
  // A = [0, I_c, A_q] over ν = (ẋ_c, ω_b, q̇).
  A_.leftCols<3>().setZero();
  A_.block<3, 3>(0, 3) = data.Ic;
  A_.rightCols(n) = data.Ag.bottomRows<3>().rightCols(n);

  for (size_t c = 0; c < legs_.size(); ++c) JL_.col(static_cast<int>(c)) = Jp_.col(legs_[c]);
  for (size_t c = 0; c < free_.size(); ++c) JF_.col(static_cast<int>(c)) = Jp_.col(free_[c]);
  lu_.compute(JL_);
  rcond_ = lu_.rcond();
  singular_ = !(rcond_ >= rcond_min);
  if (singular_) return false;
  valid_ = true;

  // Ā = [A_νc − B Ad, B, A_F − B J'_F] with B = A_L J'_L⁻¹.
  Eigen::Matrix<double, 3, 12> AL;
  for (size_t c = 0; c < legs_.size(); ++c) AL.col(static_cast<int>(c)) = A_.col(6 + legs_[c]);
  // Bᵀ = J'_L⁻ᵀ A_Lᵀ with P J'_L = L U:  J'_L⁻ᵀ = Pᵀ L⁻ᵀ U⁻ᵀ.
  Eigen::Matrix<double, 12, 3> Bt = AL.transpose();
  lu_.matrixLU().triangularView<Eigen::Upper>().transpose().solveInPlace(Bt);
  lu_.matrixLU().triangularView<Eigen::UnitLower>().transpose().solveInPlace(Bt);
  Bt = lu_.permutationP().transpose() * Bt;
  const Eigen::Matrix<double, 3, 12> B = Bt.transpose();
  Abar_.leftCols<6>() = A_.leftCols<6>() - B * Ad_;
  Abar_.block<3, 12>(0, 6) = B;
  for (size_t c = 0; c < free_.size(); ++c) {
    Abar_.col(kFree + static_cast<int>(c)) = A_.col(6 + free_[c]) - B * JF_.col(static_cast<int>(c));
  }
  return true;
}

void TaskSpace::apply(const ConstVector& nu, Eigen::Ref<Eigen::VectorXd> xdot) const {
  xdot.head<6>() = nu.head<6>();
  xdot.segment<12>(6) = Ad_ * nu.head<6>() + Jp_ * nu.tail(n_);
  for (size_t c = 0; c < free_.size(); ++c) xdot(kFree + static_cast<int>(c)) = nu(6 + free_[c]);
}

void TaskSpace::solve(const ConstVector& xdot, Eigen::Ref<Eigen::VectorXd> nu) const {
  nu.head<6>() = xdot.head<6>();
  Eigen::Matrix<double, 12, 1> rhs = xdot.segment<12>(6) - Ad_ * xdot.head<6>();
  for (size_t c = 0; c < free_.size(); ++c) {
    const double qf = xdot(kFree + static_cast<int>(c));
    nu(6 + free_[c]) = qf;
    rhs -= JF_.col(static_cast<int>(c)) * qf;
  }
  const Eigen::Matrix<double, 12, 1> qL = lu_.solve(rhs);
  for (size_t c = 0; c < legs_.size(); ++c) nu(6 + legs_[c]) = qL(static_cast<int>(c));
}

void TaskSpace::apply_transpose(const ConstVector& w, Eigen::Ref<Eigen::VectorXd> out) const {
  out.head<6>() = w.head<6>() + Ad_.transpose() * w.segment<12>(6);
  out.tail(n_).noalias() = Jp_.transpose() * w.segment<12>(6);
  for (size_t c = 0; c < free_.size(); ++c) out(6 + free_[c]) += w(kFree + static_cast<int>(c));
}

void TaskSpace::jacobian(Eigen::MatrixXd& J) const {
  J.setZero(nbar_, nbar_);
  J.topLeftCorner<6, 6>().setIdentity();
  J.block<12, 6>(6, 0) = Ad_;
  J.block(6, 6, 12, n_) = Jp_;
  for (size_t c = 0; c < free_.size(); ++c) J(kFree + static_cast<int>(c), 6 + free_[c]) = 1.0;
}

void TaskSpace::jacobian_inverse(Eigen::MatrixXd& Jinv) const {
  Jinv.resize(nbar_, nbar_);
  Eigen::VectorXd e = Eigen::VectorXd::Zero(nbar_);
  for (int k = 0; k < nbar_; ++k) {
    e.setZero();
    e(k) = 1.0;
    solve(e, Jinv.col(k));
  }
}

}  // namespace hpr::model
