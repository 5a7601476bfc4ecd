#include "hpr/qp/qp_solver.hpp"

#include "internal.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

namespace hpr::qp {

using detail::kInf;

std::string_view to_string(Status s) {
  switch (s) {
    case Status::kOptimal: return "optimal";
    case Status::kIterationLimit: return "working-set change limit reached";
    case Status::kInfeasible: return "infeasible";
    case Status::kInvalidDimensions: return "invalid dimensions";
    case Status::kNonFinite: return "non-finite input";
    case Status::kInconsistentBounds: return "lower bound above upper bound";
    case Status::kNotPositiveDefinite: return "H not symmetric positive definite";
    case Status::kNumericalFailure: return "numerical failure";
  }
  return "unknown";
}

double KktResiduals::max() const { return std::max({stationarity, primal, dual, complementarity}); }

Solver::Solver(int n, int m, Options options)
    : n_(n),
      m_(m),
      options_(options),
      H_(Matrix::Zero(n, n)),
      A_(Matrix::Zero(m, n)),
      g_(Vector::Zero(n)),
      lb_(Vector::Zero(n)),
      ub_(Vector::Zero(n)),
      lbA_(Vector::Zero(m)),
      ubA_(Vector::Zero(m)),
      row_norm_(Vector::Ones(m)),
      L_(Matrix::Zero(n, n)),
      J_(Matrix::Zero(n, n)),
      J0_(Matrix::Zero(n, n)),
      R_(Matrix::Zero(n, n)),
      bound_state_(static_cast<size_t>(n), Active::kInactive),
      constraint_state_(static_cast<size_t>(m), Active::kInactive),
      x_(Vector::Zero(n)),
      u_(Vector::Zero(n)),
      Ax_(Vector::Zero(m)),
      d_(Vector::Zero(n)),
      z_(Vector::Zero(n)),
      r_(Vector::Zero(n)),
      grad_(Vector::Zero(n)),
      tmp_(Vector::Zero(n)),
      b_w_(Vector::Zero(n)),
      best_x_(Vector::Zero(n)),
      prev_x_(Vector::Zero(n)),
      y_bounds_(Vector::Zero(n)),
      y_constraints_(Vector::Zero(m)),
      Hf_(Matrix::Zero(n, n)),
      Nf_(Matrix::Zero(n, n)),
      Y_(Matrix::Zero(n, n)),
      S_(Matrix::Zero(n, n)),
      gf_(Vector::Zero(n)),
      xf_(Vector::Zero(n)),
      xb_(Vector::Zero(n)),
      rhs_(Vector::Zero(n)),
      uf_(Vector::Zero(n)),
      rinv_(Vector::Zero(n)) {
  free_.reserve(static_cast<size_t>(n));
  rows_.reserve(static_cast<size_t>(n));
  row_entry_.reserve(static_cast<size_t>(n));
  bound_entry_.assign(static_cast<size_t>(n), -1);
  trial_.reserve(static_cast<size_t>(n));
  active_.reserve(static_cast<size_t>(n));
  previous_active_.reserve(static_cast<size_t>(n));
}

void Solver::reset() {
  previous_active_.clear();
  have_previous_ = false;
}

Status Solver::solve_cold(const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb,
                          const ConstVector& ub, const ConstVector& lbA, const ConstVector& ubA) {
  return solve(false, H, g, A, lb, ub, lbA, ubA);
}

Status Solver::solve_hot(const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb,
                         const ConstVector& ub, const ConstVector& lbA, const ConstVector& ubA) {
  return solve(true, H, g, A, lb, ub, lbA, ubA);
}

Status Solver::validate(const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb,
                        const ConstVector& ub, const ConstVector& lbA, const ConstVector& ubA) const {
  if (H.rows() != n_ || H.cols() != n_ || g.size() != n_ || lb.size() != n_ || ub.size() != n_ ||
      lbA.size() != m_ || ubA.size() != m_ || (m_ > 0 && (A.rows() != m_ || A.cols() != n_))) {
    return Status::kInvalidDimensions;
  }
  if (!std::isfinite(g.sum())) return Status::kNonFinite;
  for (int i = 0; i < n_; ++i) {
    const double l = lb(i), u = ub(i);
    if (std::isnan(l) || std::isnan(u)) return Status::kNonFinite;
    if (l > u || l == kInf || u == -kInf) return Status::kInconsistentBounds;
  }
  for (int j = 0; j < m_; ++j) {
    const double l = lbA(j), u = ubA(j);
    if (std::isnan(l) || std::isnan(u)) return Status::kNonFinite;
    if (l > u || l == kInf || u == -kInf) return Status::kInconsistentBounds;
  }
  return Status::kOptimal;
}

void Solver::update_constraint_values() {
  if (m_ > 0) Ax_.noalias() = A_ * x_;
}

void Solver::compute_multipliers() {
  const int q = static_cast<int>(active_.size());
  grad_.noalias() = H_ * x_;
  grad_ += g_;
  if (q == 0) return;
  tmp_.head(q).noalias() = J_.leftCols(q).transpose() * grad_;
  R_.topLeftCorner(q, q).triangularView<Eigen::Upper>().solveInPlace(tmp_.head(q));
  u_.head(q) = tmp_.head(q);
}

void Solver::solve_working_set() {
  // x = −J2 J2ᵀ g + J1 R⁻ᵀ b_W, then the multipliers.
  const int q = static_cast<int>(active_.size());
  tmp_.head(n_ - q).noalias() = J_.rightCols(n_ - q).transpose() * g_;
  x_.noalias() = -J_.rightCols(n_ - q) * tmp_.head(n_ - q);
  if (q > 0) {
    for (int i = 0; i < q; ++i) b_w_(i) = rhs(active_[static_cast<size_t>(i)]);
    R_.topLeftCorner(q, q).transpose().triangularView<Eigen::Lower>().solveInPlace(b_w_.head(q));
    x_.noalias() += J_.leftCols(q) * b_w_.head(q);
  }
  update_constraint_values();
  compute_multipliers();
}

int Solver::most_violated(double* slack, double* sign) {
  if (!row_norms_current_) {
    for (int j = 0; j < m_; ++j) row_norm_(j) = std::max(1e-300, A_.row(j).norm());
    row_norms_current_ = true;
  }
  int best = -1;
  double worst = 0.0;
  auto is_active = [&](int c) {
    return c < n_ ? bound_state_[static_cast<size_t>(c)] != Active::kInactive
                  : constraint_state_[static_cast<size_t>(c - n_)] != Active::kInactive;
  };
  for (int c = 0; c < n_ + m_; ++c) {
    if (is_active(c)) continue;
    const double v = value(c), l = lower(c), u = upper(c);
    const double norm = c < n_ ? 1.0 : row_norm_(c - n_);
    if (v < l - options_.primal_tolerance * (1.0 + std::abs(l))) {
      const double viol = (l - v) / norm;
      if (viol > worst) {
        worst = viol;
        best = c;
        *slack = v - l;
        *sign = 1.0;
      }
    } else if (v > u + options_.primal_tolerance * (1.0 + std::abs(u))) {
      const double viol = (v - u) / norm;
      if (viol > worst) {
        worst = viol;
        best = c;
        *slack = u - v;
        *sign = -1.0;
      }
    }
  }
  return best;
}

bool Solver::is_feasible() const {
  const double tol = options_.primal_tolerance;
  for (int i = 0; i < n_; ++i) {
    const double v = x_(i), l = lb_(i), u = ub_(i);
    if (v < l - tol * (1.0 + std::abs(l)) || v > u + tol * (1.0 + std::abs(u))) return false;
  }
  for (int j = 0; j < m_; ++j) {
    const double v = Ax_(j), l = lbA_(j), u = ubA_(j);
    if (v < l - tol * (1.0 + std::abs(l)) || v > u + tol * (1.0 + std::abs(u))) return false;
  }
  return true;
}

double Solver::evaluate_objective(const Vector& x) const { return 0.5 * x.dot(H_ * x) + g_.dot(x); }

void Solver::consider_candidate() {
  const double obj = evaluate_objective(x_);
  if (!have_best_ || obj < best_obj_) {
    best_x_ = x_;
    best_obj_ = obj;
    have_best_ = true;
  }
}

// Marks the working set in the per-constraint state arrays.
void Solver::finish(Status s) {
  status_ = s;
  kkt_current_ = objective_current_ = false;
  const bool valid_data = !(s == Status::kInvalidDimensions || s == Status::kNonFinite ||
                            s == Status::kInconsistentBounds || s == Status::kNotPositiveDefinite);
  if (!valid_data) {
    primal_feasible_ = false;
    kkt_ = KktResiduals{};
    kkt_current_ = true;
    return;
  }
  update_constraint_values();
  bool feasible = is_feasible();
  // The working set reached is kept for the next hot start even when the cap stopped the solve, so
  // that a sequence of capped solves keeps making progress.
  if (s == Status::kOptimal || s == Status::kIterationLimit) previous_active_ = active_;
  if (s == Status::kIterationLimit && !feasible) {
    // The previous solution is a candidate too, if it is feasible for this problem.
    if (have_previous_) {
      x_.swap(prev_x_);
      update_constraint_values();
      if (is_feasible()) consider_candidate();
      x_.swap(prev_x_);
      update_constraint_values();
    }
    if (have_best_) {
      // Return the best feasible point seen instead of an infeasible iterate.
      x_ = best_x_;
      update_constraint_values();
      feasible = true;
      active_.clear();  // its multipliers are unknown; report the point without a working set
    }
  }
  primal_feasible_ = feasible;
  if (s == Status::kOptimal || s == Status::kIterationLimit) compute_multipliers();
  detail::mark(active_, n_, bound_state_, constraint_state_);
  y_bounds_.setZero();
  y_constraints_.setZero();
  for (int i = 0; i < static_cast<int>(active_.size()); ++i) {
    const Entry& e = active_[static_cast<size_t>(i)];
    const double y = e.sign * u_(i);
    if (e.c < n_) {
      y_bounds_(e.c) = y;
    } else {
      y_constraints_(e.c - n_) = y;
    }
  }
  if (s == Status::kOptimal || (s == Status::kIterationLimit && primal_feasible_)) {
    prev_x_ = x_;
    have_previous_ = true;
  }
}

double Solver::objective() const {
  if (!objective_current_) {
    objective_ = evaluate_objective(x_);
    objective_current_ = true;
  }
  return objective_;
}

const KktResiduals& Solver::kkt() const {
  if (kkt_current_) return kkt_;
  kkt_current_ = true;
  Vector grad = H_ * x_ + g_ - y_bounds_;
  if (m_ > 0) grad -= A_.transpose() * y_constraints_;
  const Vector Ax = m_ > 0 ? Vector(A_ * x_) : Vector();
  kkt_.stationarity = grad.cwiseAbs().maxCoeff();
  kkt_.primal = kkt_.dual = kkt_.complementarity = 0.0;
  for (int c = 0; c < n_ + m_; ++c) {
    const double v = c < n_ ? x_(c) : Ax(c - n_), l = lower(c), u = upper(c);
    kkt_.primal = std::max({kkt_.primal, l - v, v - u});
    const double y = c < n_ ? y_bounds_(c) : y_constraints_(c - n_);
    const Active st = c < n_ ? bound_state_[static_cast<size_t>(c)] : constraint_state_[static_cast<size_t>(c - n_)];
    if (st == Active::kEquality) continue;
    if (y > 0) {
      kkt_.complementarity = std::max(kkt_.complementarity, y * std::max(0.0, v - l));
    } else if (y < 0) {
      kkt_.complementarity = std::max(kkt_.complementarity, -y * std::max(0.0, u - v));
    }
    if (st == Active::kLower) kkt_.dual = std::max(kkt_.dual, -y);
    if (st == Active::kUpper) kkt_.dual = std::max(kkt_.dual, y);
  }
  return kkt_;
}

}  // namespace hpr::qp
