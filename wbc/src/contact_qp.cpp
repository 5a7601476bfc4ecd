#include "hpr/wbc/contact_qp.hpp"

#include <cassert>
#include <cmath>
#include <limits>

#include "hpr/common/time.hpp"

namespace hpr::wbc {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

// G_i: CoM wrench of the foot wrench w_i = (f, τ) at the sole centre p: (f, τ + (p − c) × f).
Eigen::Matrix<double, 6, 6> contact_map(const Eigen::Vector3d& p, const Eigen::Vector3d& com) {
  Eigen::Matrix<double, 6, 6> G = Eigen::Matrix<double, 6, 6>::Identity();
  G.block<3, 3>(3, 0) = model::skew(p - com);
  return G;
}
}  // namespace

ContactQp::ContactQp(ContactParams params) : params_(params) {
  for (int exact = 0; exact < 2; ++exact) {
    const qp::Options opt{params.max_working_set_changes * (exact != 0 ? 1 : 3), 1e-10, 1e-12, 1e-12};
    for (int na = 1; na <= 2; ++na) {
      solvers_[static_cast<size_t>(exact)][static_cast<size_t>(na - 1)] =
          std::make_unique<qp::Solver>(6 * na, rows_per_foot(params) * na + (exact != 0 ? 6 : 0), opt);
    }
  }
}

void ContactQp::foot_constraints(const Contact& c, const ContactParams& p, Eigen::Ref<Eigen::MatrixXd> C,
                                 Eigen::Ref<Eigen::VectorXd> lb, Eigen::Ref<Eigen::VectorXd> ub) {
  // Rows on the local wrench (f_x, f_y, f_z, τ_x, τ_y, τ_z), then rotated to world axes.
  Eigen::Matrix<double, kMaxRowsPerFoot, 6> L = Eigen::Matrix<double, kMaxRowsPerFoot, 6>::Zero();
  const int rows = rows_per_foot(p);
  assert(C.rows() == rows && lb.size() == rows && ub.size() == rows);
  lb.setConstant(-kInf);
  ub.setZero();
  const double mu = p.friction * std::cos(M_PI / 8);  // octagon inscribed in the cone
  for (int k = 0; k < 8; ++k) {
    const double th = k * M_PI / 4;
    L(k, 0) = std::cos(th);
    L(k, 1) = std::sin(th);
    L(k, 2) = -mu;
  }
  const double hx = std::max(0.0, 0.5 * c.length - p.cop_margin), hy = std::max(0.0, 0.5 * c.width - p.cop_margin);
  // CoP (p_x, p_y) = (−τ_y, τ_x) / f_z inside [−hx, hx] x [−hy, hy].
  L(8, 3) = 1;   L(8, 2) = -hy;   // τ_x ≤ hy f_z
  L(9, 3) = -1;  L(9, 2) = -hy;   // −τ_x ≤ hy f_z
  L(10, 4) = 1;  L(10, 2) = -hx;  // τ_y ≤ hx f_z
  L(11, 4) = -1; L(11, 2) = -hx;
  L(12, 5) = 1;  L(12, 2) = -p.torsion;
  L(13, 5) = -1; L(13, 2) = -p.torsion;
  // The torsion of a rectangle of four corner contacts, each in a friction pyramid |f_x|, |f_y| ≤
  // μ_p f_z (the pyramid inside the cone, μ_p = μ/√2), at the CoP (−τ_y, τ_x)/f_z:
  //   τ_z ≤ μ_p (X + Y) f_z − |Y f_x + μ_p τ_x| − |X f_y + μ_p τ_y|,
  //   τ_z ≥ −μ_p (X + Y) f_z + |Y f_x − μ_p τ_x| + |X f_y − μ_p τ_y|,
  // the whole range at the centre, at a corner only the corner force's own (a sole on its corner turns
  // about it).
  if (p.sole_torsion) {
    const double mp = p.friction / std::sqrt(2.0);
    int r = kBaseRowsPerFoot;
    for (const double s1 : {-1.0, 1.0}) {
      for (const double s2 : {-1.0, 1.0}) {
        // sz = 1: τ_z + s1 (Y f_x + μ_p τ_x) + s2 (X f_y + μ_p τ_y) − μ_p (X + Y) f_z ≤ 0;
        // sz = −1: −τ_z + s1 (Y f_x − μ_p τ_x) + s2 (X f_y − μ_p τ_y) − μ_p (X + Y) f_z ≤ 0.
        for (const double sz : {1.0, -1.0}) {
          L(r, 5) = sz;
          L(r, 0) = s1 * hy; L(r, 3) = sz * s1 * mp;
          L(r, 1) = s2 * hx; L(r, 4) = sz * s2 * mp;
          L(r, 2) = -mp * (hx + hy);
          ++r;
        }
      }
    }
  }
  L(14, 2) = 1;  // f_z ≥ f_min
  lb(14) = p.min_normal_force;
  ub(14) = kInf;
  L(15, 2) = 1;  // f_z ≤ load f_max
  lb(15) = -kInf;
  ub(15) = std::max(p.min_normal_force, c.load_limit * p.max_normal_force);
  // Local wrench = blockdiag(Rᵀ, Rᵀ) w  →  rows L blockdiag(Rᵀ, Rᵀ).
  const model::Matrix3d Rt = c.X_WS.R.transpose();
  C.leftCols(3) = L.topRows(rows).leftCols<3>() * Rt;
  C.rightCols(3) = L.topRows(rows).rightCols<3>() * Rt;
}

qp::Status ContactQp::solve(const std::array<Contact, 2>& contacts, const Eigen::Vector3d& com,
                            const model::Vector6d& w_des) {
  int active[2], na = 0;
  for (int k = 0; k < 2; ++k) {
    if (contacts[static_cast<size_t>(k)].active) active[na++] = k;
  }
  w_[0].setZero();
  w_[1].setZero();
  achieved_.setZero();
  iterations_ = 0;
  solve_time_us_ = 0;
  exact_ = valid_ = false;
  if (na == 0) return qp::Status::kInfeasible;
  const double t0 = monotonic_s();
  qp::Status s = solve_mode(true, na, active, contacts, com, w_des);
  int iterations = iterations_;
  if (s == qp::Status::kOptimal) {
    exact_ = true;
  } else {
    s = solve_mode(false, na, active, contacts, com, w_des);
    iterations += iterations_;
  }
  iterations_ = iterations;
  solve_time_us_ = (monotonic_s() - t0) * 1e6;
  return s;
}

qp::Status ContactQp::solve_mode(bool exact, int na, const int* active, const std::array<Contact, 2>& contacts,
                                 const Eigen::Vector3d& com, const model::Vector6d& w_des) {
  qp::Solver& solver = *solvers_[exact ? 1 : 0][static_cast<size_t>(na - 1)];
  if (na == 1 && last_single_foot_[exact ? 1 : 0] != active[0]) {
    solver.reset();  // the other foot: its working set means nothing here
    last_single_foot_[exact ? 1 : 0] = active[0];
  }
  const int rows = rows_per_foot(params_), n = 6 * na, mc = rows * na, m = mc + (exact ? 6 : 0);
  H_.resize(n, n);
  g_.resize(n);
  A_.resize(m, n);
  A_.setZero();
  lbA_.resize(m);
  ubA_.resize(m);
  lb_ = Eigen::VectorXd::Constant(n, -kInf);
  ub_ = Eigen::VectorXd::Constant(n, kInf);
  Eigen::Matrix<double, 6, 12> G = Eigen::Matrix<double, 6, 12>::Zero();
  for (int a = 0; a < na; ++a) {
    const Contact& c = contacts[static_cast<size_t>(active[a])];
    G.block<6, 6>(0, 6 * a) = contact_map(c.X_WS.p, com);
    foot_constraints(c, params_, A_.block(rows * a, 6 * a, rows, 6), lbA_.segment(rows * a, rows), ubA_.segment(rows * a, rows));
  }
  const auto Gn = G.leftCols(n);
  Eigen::Matrix<double, 12, 1> R;
  for (int a = 0; a < 2; ++a) {
    R.segment<3>(6 * a).setConstant(params_.distribution_force);
    R.segment<3>(6 * a + 3).setConstant(params_.distribution_torque);
  }
  if (exact) {
    // min ½ wᵀ R w  s.t.  G w = w_des and the contact constraints.
    H_ = R.head(n).asDiagonal();
    g_.setZero();
    A_.bottomRows(6) = Gn;
    lbA_.tail<6>() = w_des;
    ubA_.tail<6>() = w_des;
  } else {
    model::Vector6d W;
    W << params_.force_weight, params_.force_weight, params_.force_weight, params_.torque_weight,
        params_.torque_weight, params_.torque_weight;
    H_.noalias() = Gn.transpose() * W.asDiagonal() * Gn;
    H_.diagonal() += params_.regularization * R.head(n);
    // ρ_t, ρ_z with two soles on the ground (one alone has no internal forces to spend), along and
    // about world z, the level ground's normal: not the soles' (a sole rolled onto its toe carries
    // its weight along its own plane).
    if (na == 2) {
      for (int a = 0; a < na; ++a) {
        H_(6 * a, 6 * a) += params_.tangential_weight;
        H_(6 * a + 1, 6 * a + 1) += params_.tangential_weight;
        H_(6 * a + 5, 6 * a + 5) += params_.torsion_weight;
      }
    }
    g_.noalias() = -(Gn.transpose() * W.asDiagonal() * w_des);
  }
  const qp::Status s = solver.solve_hot(H_, g_, A_, lb_, ub_, lbA_, ubA_);
  iterations_ = solver.working_set_changes();
  if (qp::usable(s) && solver.primal_feasible()) {
    for (int a = 0; a < na; ++a) w_[static_cast<size_t>(active[a])] = solver.x().segment<6>(6 * a);
    achieved_ = Gn * solver.x();
    valid_ = true;
    return s;
  }
  return s == qp::Status::kOptimal ? qp::Status::kNumericalFailure : s;
}

}  // namespace hpr::wbc
