#include "hpr/qp/qp_solver.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

namespace hpr::qp {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

// Givens rotation (c, s) with [c s; -s c] [a; b] = [r; 0].
inline void givens(double a, double b, double& c, double& s, double& r) {
  if (b == 0.0) {
    c = 1.0;
    s = 0.0;
    r = a;
    return;
  }
  r = std::sqrt(a * a + b * b);
  c = a / r;
  s = b / r;
}
}  // namespace

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

bool Solver::factorize() {
  // Cholesky H = L Lᵀ in place (lower triangle of L_), then J = L⁻ᵀ.
  L_ = H_;
  const double scale = std::max(1.0, H_.cwiseAbs().maxCoeff());
  for (int j = 0; j < n_; ++j) {
    double djj = L_(j, j) - L_.row(j).head(j).squaredNorm();
    if (!(djj > 1e-14 * scale)) return false;
    djj = std::sqrt(djj);
    L_(j, j) = djj;
    for (int i = j + 1; i < n_; ++i) {
      L_(i, j) = (L_(i, j) - L_.row(i).head(j).dot(L_.row(j).head(j))) / djj;
    }
  }
  // J0 = L⁻ᵀ (upper triangular): column j solves Lᵀ x = e_j.
  J0_.setZero();
  for (int j = 0; j < n_; ++j) {
    J0_(j, j) = 1.0 / L_(j, j);
    for (int i = j - 1; i >= 0; --i) {
      double acc = 0.0;
      for (int k = i + 1; k <= j; ++k) acc += L_(k, i) * J0_(k, j);
      J0_(i, j) = -acc / L_(i, i);
    }
  }
  J_ = J0_;
  return true;
}

double Solver::lower(int c) const { return c < n_ ? lb_(c) : lbA_(c - n_); }
double Solver::upper(int c) const { return c < n_ ? ub_(c) : ubA_(c - n_); }
double Solver::value(int c) const { return c < n_ ? x_(c) : Ax_(c - n_); }

void Solver::normal_times_J(int c, double sign) {
  if (c < n_) {
    d_.noalias() = sign * J_.row(c).transpose();
  } else {
    d_.noalias() = J_.transpose() * A_.row(c - n_).transpose();
    d_ *= sign;
  }
}

bool Solver::add_to_factorization(const Entry& e) {
  const int q = static_cast<int>(active_.size());
  normal_times_J(e.c, e.sign);
  const double scale = std::max(1.0, d_.norm());
  if (d_.tail(n_ - q).norm() <= options_.dependency_tolerance * scale) return false;
  // Rotate d[q..n) into d[q], applying the same rotations to the columns of J.
  for (int j = n_ - 1; j > q; --j) {
    double c = 0, s = 0, r = 0;
    givens(d_(j - 1), d_(j), c, s, r);
    if (s == 0.0) continue;
    d_(j - 1) = r;
    d_(j) = 0.0;
    for (int i = 0; i < n_; ++i) {
      const double a = J_(i, j - 1), b = J_(i, j);
      J_(i, j - 1) = c * a + s * b;
      J_(i, j) = -s * a + c * b;
    }
  }
  R_.col(q).head(q + 1) = d_.head(q + 1);
  active_.push_back(e);
  return true;
}

void Solver::drop_from_factorization(int k) {
  const int q = static_cast<int>(active_.size());
  // Remove column k of R, then restore the triangle with rotations of rows (j, j+1).
  for (int j = k; j < q - 1; ++j) R_.col(j).head(j + 2) = R_.col(j + 1).head(j + 2);
  for (int j = k; j < q - 1; ++j) {
    double c = 0, s = 0, r = 0;
    givens(R_(j, j), R_(j + 1, j), c, s, r);
    R_(j, j) = r;
    R_(j + 1, j) = 0.0;
    for (int col = j + 1; col < q - 1; ++col) {
      const double a = R_(j, col), b = R_(j + 1, col);
      R_(j, col) = c * a + s * b;
      R_(j + 1, col) = -s * a + c * b;
    }
    for (int i = 0; i < n_; ++i) {
      const double a = J_(i, j), b = J_(i, j + 1);
      J_(i, j) = c * a + s * b;
      J_(i, j + 1) = -s * a + c * b;
    }
  }
  for (int i = k; i < q - 1; ++i) u_(i) = u_(i + 1);
  active_.erase(active_.begin() + k);
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
namespace {
template <class Entries>
void mark(const Entries& active, int n, std::vector<Active>& bounds, std::vector<Active>& rows) {
  std::fill(bounds.begin(), bounds.end(), Active::kInactive);
  std::fill(rows.begin(), rows.end(), Active::kInactive);
  for (const auto& e : active) {
    const Active s = e.equality ? Active::kEquality : (e.sign > 0 ? Active::kLower : Active::kUpper);
    if (e.c < n) {
      bounds[static_cast<size_t>(e.c)] = s;
    } else {
      rows[static_cast<size_t>(e.c - n)] = s;
    }
  }
}
}  // namespace

Status Solver::run_dual() {
  int refinements = 0;
  while (true) {
    mark(active_, n_, bound_state_, constraint_state_);
    double s = 0, sign = 1;
    const int p = most_violated(&s, &sign);
    if (p < 0) {
      // Remove the drift of the updates: re-solve the working set exactly, then re-check. A point
      // that violates its own working set after that is a numerical failure, not a loop.
      solve_working_set();
      if (is_feasible()) return Status::kOptimal;
      if (++refinements > 2) return Status::kNumericalFailure;
      continue;
    }
    const Entry e{p, sign, lower(p) == upper(p)};
    double u_plus = 0.0;
    while (true) {
      const int q = static_cast<int>(active_.size());
      normal_times_J(p, sign);
      const double d2 = d_.tail(n_ - q).squaredNorm();
      const bool dependent = std::sqrt(d2) <= options_.dependency_tolerance * std::max(1.0, d_.norm());
      if (q > 0) {
        r_.head(q) = d_.head(q);
        R_.topLeftCorner(q, q).triangularView<Eigen::Upper>().solveInPlace(r_.head(q));
      }
      double t1 = kInf;
      int k = -1;
      for (int i = 0; i < q; ++i) {
        if (active_[static_cast<size_t>(i)].equality) continue;
        if (r_(i) > 1e-14 && u_(i) / r_(i) < t1) {
          t1 = u_(i) / r_(i);
          k = i;
        }
      }
      const double t2 = dependent ? kInf : -s / d2;
      if (t1 == kInf && t2 == kInf) return Status::kInfeasible;
      if (t2 <= t1) {
        z_.noalias() = J_.rightCols(n_ - q) * d_.tail(n_ - q);
        x_ += t2 * z_;
        if (q > 0) u_.head(q) -= t2 * r_.head(q);
        u_plus += t2;
        update_constraint_values();
        add_to_factorization(e);
        u_(q) = u_plus;
        ++changes_;
        break;
      }
      // Partial step: a multiplier reaches zero first; that constraint leaves.
      if (!dependent) {
        z_.noalias() = J_.rightCols(n_ - q) * d_.tail(n_ - q);
        x_ += t1 * z_;
        s += t1 * d2;
        update_constraint_values();
      }
      u_.head(q) -= t1 * r_.head(q);
      u_plus += t1;
      drop_from_factorization(k);
      ++changes_;
      if (changes_ >= options_.max_working_set_changes) return Status::kIterationLimit;
    }
    if (changes_ >= options_.max_working_set_changes) {
      mark(active_, n_, bound_state_, constraint_state_);
      if (most_violated(&s, &sign) < 0) {
        solve_working_set();
        if (is_feasible()) return Status::kOptimal;
      }
      return Status::kIterationLimit;
    }
  }
}

Status Solver::run_primal() {
  // Every iterate stays feasible. A full step reaches the minimiser on the working set, where the
  // multipliers decide: all of the right sign is optimal, else the most negative constraint leaves.
  bool at_working_set_minimum = false;
  while (true) {
    const int q = static_cast<int>(active_.size());
    if (!at_working_set_minimum) {
      grad_.noalias() = H_ * x_;
      grad_ += g_;
      tmp_.head(n_ - q).noalias() = J_.rightCols(n_ - q).transpose() * grad_;
      z_.noalias() = -J_.rightCols(n_ - q) * tmp_.head(n_ - q);
      at_working_set_minimum = z_.norm() <= 1e-13 * (1.0 + x_.norm());
    }
    if (at_working_set_minimum) {
      compute_multipliers();
      const double scale = std::max(1.0, grad_.cwiseAbs().maxCoeff());
      int k = -1;
      double most = -options_.dual_tolerance * scale;
      for (int i = 0; i < q; ++i) {
        if (!active_[static_cast<size_t>(i)].equality && u_(i) < most) {
          most = u_(i);
          k = i;
        }
      }
      if (k < 0) return Status::kOptimal;
      drop_from_factorization(k);
      ++changes_;
      mark(active_, n_, bound_state_, constraint_state_);
      if (changes_ >= options_.max_working_set_changes) return Status::kIterationLimit;
      at_working_set_minimum = false;
      continue;
    }
    // Ratio test along z.
    double alpha = 1.0;
    int block = -1;
    double block_sign = 1.0;
    for (int c = 0; c < n_ + m_; ++c) {
      const bool act = c < n_ ? bound_state_[static_cast<size_t>(c)] != Active::kInactive
                              : constraint_state_[static_cast<size_t>(c - n_)] != Active::kInactive;
      if (act) continue;
      const double np = c < n_ ? z_(c) : A_.row(c - n_).dot(z_);
      const double v = value(c);
      if (np < -1e-14) {
        const double l = lower(c);
        if (l > -kInf) {
          const double a = std::max(0.0, (v - l) / -np);
          if (a < alpha) {
            alpha = a;
            block = c;
            block_sign = 1.0;
          }
        }
      } else if (np > 1e-14) {
        const double u = upper(c);
        if (u < kInf) {
          const double a = std::max(0.0, (u - v) / np);
          if (a < alpha) {
            alpha = a;
            block = c;
            block_sign = -1.0;
          }
        }
      }
    }
    x_ += alpha * z_;
    update_constraint_values();
    consider_candidate();
    if (block < 0) {
      at_working_set_minimum = true;
      continue;
    }
    if (add_to_factorization(Entry{block, block_sign, false})) {
      u_(static_cast<int>(active_.size()) - 1) = 0.0;
      mark(active_, n_, bound_state_, constraint_state_);
    }
    ++changes_;
    if (changes_ >= options_.max_working_set_changes) return Status::kIterationLimit;
  }
}

Status Solver::solve(bool hot, const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb,
                     const ConstVector& ub, const ConstVector& lbA, const ConstVector& ubA) {
  changes_ = 0;
  have_best_ = false;
  const Status v = validate(H, g, A, lb, ub, lbA, ubA);
  if (v != Status::kOptimal) {
    finish(v);
    return v;
  }
  // Copy H and A, detect an unchanged H (its factorisation is kept) and check finiteness: a sum is
  // finite exactly when every term is, short of an overflow that is no valid input either. Eigen's
  // sum runs on several SIMD accumulators; a scalar running sum would be one long dependency chain.
  const bool same_H = H_factorized_ && H_ == H;
  H_ = H;
  double sum = H_.sum();
  const double hscale = std::max(1.0, H_.diagonal().cwiseAbs().maxCoeff());
  if (m_ > 0) {
    A_ = A;
    sum += A_.sum();
  }
  double asymmetry = 0.0;
  for (int j = 0; j < n_; ++j) {
    for (int i = 0; i < j; ++i) asymmetry = std::max(asymmetry, std::abs(H_(i, j) - H_(j, i)));
  }
  const bool symmetric = asymmetry <= 1e-12 * hscale;
  if (!std::isfinite(sum) || !symmetric) {
    H_factorized_ = false;
    const Status bad = !std::isfinite(sum) ? Status::kNonFinite : Status::kNotPositiveDefinite;
    finish(bad);
    return bad;
  }
  if (!same_H) H_factorized_ = false;
  g_ = g;
  lb_ = lb;
  ub_ = ub;
  lbA_ = lbA;
  ubA_ = ubA;
  kkt_current_ = objective_current_ = false;
  row_norms_current_ = false;

  // Fast path: most hot starts keep their working set; solve it directly and accept a KKT point.
  // When the data moved a constraint in or out, a few single changes of the working set, each
  // solved the same way, usually reach the KKT point at a fraction of a refactorisation.
  if (hot && have_previous_) {
    trial_ = previous_active_;
    constexpr int kRetries = 3;  // each one working-set change, within the cap
    const int attempts = std::min(kRetries, options_.max_working_set_changes);
    for (int attempt = 0; attempt <= attempts; ++attempt) {
      Entry add{};
      int drop = -1;
      const FastPath r = try_working_set(trial_, &add, &drop);
      if (r == FastPath::kOptimal) {
        changes_ = attempt;
        previous_active_ = active_;
        status_ = Status::kOptimal;
        primal_feasible_ = true;
        prev_x_ = x_;
        return status_;
      }
      if (r == FastPath::kFailed) break;
      if (r == FastPath::kAdd) {
        if (static_cast<int>(trial_.size()) >= n_) break;
        trial_.push_back(add);
      } else {
        trial_.erase(trial_.begin() + drop);
      }
    }
  }

  if (!H_factorized_) {
    H_factorized_ = factorize();
    if (!H_factorized_) {
      finish(Status::kNotPositiveDefinite);
      return status_;
    }
  } else {
    J_ = J0_;
  }

  active_.clear();
  // Equalities first; they never leave.
  for (int c = 0; c < n_ + m_; ++c) {
    if (lower(c) == upper(c)) (void)add_to_factorization(Entry{c, 1.0, true});
  }
  if (hot) {
    for (const Entry& e : previous_active_) {
      if (e.equality || lower(e.c) == upper(e.c)) continue;
      if ((e.sign > 0 ? lower(e.c) : upper(e.c)) == (e.sign > 0 ? -kInf : kInf)) continue;
      (void)add_to_factorization(e);
    }
  }
  solve_working_set();
  mark(active_, n_, bound_state_, constraint_state_);

  auto dual_ok = [&]() {
    const double scale = std::max(1.0, grad_.cwiseAbs().maxCoeff());
    int worst = -1;
    double most = -options_.dual_tolerance * scale;
    for (int i = 0; i < static_cast<int>(active_.size()); ++i) {
      if (!active_[static_cast<size_t>(i)].equality && u_(i) < most) {
        most = u_(i);
        worst = i;
      }
    }
    return worst;
  };

  Status s;
  while (true) {
    const bool feasible = is_feasible();
    const int worst = dual_ok();
    if (feasible) {
      consider_candidate();
      s = worst < 0 ? Status::kOptimal : run_primal();
      break;
    }
    if (worst < 0) {
      s = run_dual();
      break;
    }
    // Neither feasible nor dual feasible: drop the most negative multiplier and re-solve.
    drop_from_factorization(worst);
    ++changes_;
    solve_working_set();
    mark(active_, n_, bound_state_, constraint_state_);
    if (changes_ >= options_.max_working_set_changes) {
      s = Status::kIterationLimit;
      break;
    }
  }
  finish(s);
  return status_;
}

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
  mark(active_, n_, bound_state_, constraint_state_);
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

Solver::FastPath Solver::try_working_set(const std::vector<Entry>& W, Entry* add, int* drop) {
  // Bounds in W fix their variables; the rows of W are handled by a Schur complement on the free
  // variables: H_FF x_F + g_F' = N_Fᵀ u, N_F x_F = b'.
  free_.clear();
  rows_.clear();
  row_entry_.clear();
  std::fill(bound_state_.begin(), bound_state_.end(), Active::kInactive);
  std::fill(constraint_state_.begin(), constraint_state_.end(), Active::kInactive);
  bool any_bound = false;
  for (std::size_t w = 0; w < W.size(); ++w) {
    const Entry& e = W[w];
    const bool eq = lower(e.c) == upper(e.c);
    const double bound = e.sign > 0 ? lower(e.c) : upper(e.c);
    if (!std::isfinite(bound)) return FastPath::kFailed;
    const Active st = eq ? Active::kEquality : (e.sign > 0 ? Active::kLower : Active::kUpper);
    if (e.c < n_) {
      if (!any_bound) xb_.setZero();
      any_bound = true;
      xb_(e.c) = bound;
      bound_state_[static_cast<size_t>(e.c)] = st;
      bound_entry_[static_cast<size_t>(e.c)] = static_cast<int>(w);
    } else {
      constraint_state_[static_cast<size_t>(e.c - n_)] = st;
      rows_.push_back(e.c - n_);
      row_entry_.push_back(static_cast<int>(w));
    }
  }
  // Equalities missing from W (new data) make the fast path inapplicable.
  for (int i = 0; i < n_; ++i) {
    if (lb_(i) == ub_(i) && bound_state_[static_cast<size_t>(i)] == Active::kInactive) return FastPath::kFailed;
  }
  for (int j = 0; j < m_; ++j) {
    if (lbA_(j) == ubA_(j) && constraint_state_[static_cast<size_t>(j)] == Active::kInactive) return FastPath::kFailed;
  }
  for (int i = 0; i < n_; ++i) {
    if (bound_state_[static_cast<size_t>(i)] == Active::kInactive) free_.push_back(i);
  }
  const int nf = static_cast<int>(free_.size()), qg = static_cast<int>(rows_.size());
  if (qg > nf) return FastPath::kFailed;
  // Reduced Hessian and gradient: g_F' = g_F + H_FB x_B.
  if (any_bound) {
    grad_.noalias() = H_ * xb_;
  }
  if (nf == n_) {  // no bound in W: H_FF = H (one vectorised copy)
    Hf_ = H_;
    gf_ = g_;
  } else {
    for (int a = 0; a < nf; ++a) {
      const int ia = free_[static_cast<size_t>(a)];
      gf_(a) = any_bound ? g_(ia) + grad_(ia) : g_(ia);
      for (int b = a; b < nf; ++b) Hf_(b, a) = H_(free_[static_cast<size_t>(b)], ia);
    }
  }
  // Cholesky of H_FF, left-looking so that every inner loop runs down a contiguous column (the
  // lower triangle of Hf_ is column-major): L(j:, j) = (H(j:, j) − Σ_k L(j, k) L(j:, k)) / L_jj.
  // rinv_ holds 1 / L_jj.
  const double scale = std::max(1.0, H_.diagonal().cwiseAbs().maxCoeff());
  for (int j = 0; j < nf; ++j) {
    double* __restrict cj = &Hf_(0, j);
    int k = 0;
    for (; k + 1 < j; k += 2) {  // two earlier columns per sweep: half the loads and stores of column j
      const double* __restrict ck = &Hf_(0, k);
      const double* __restrict ck1 = &Hf_(0, k + 1);
      const double ljk = ck[j], ljk1 = ck1[j];
      for (int i = j; i < nf; ++i) cj[i] -= ljk * ck[i] + ljk1 * ck1[i];
    }
    if (k < j) {
      const double* __restrict ck = &Hf_(0, k);
      const double ljk = ck[j];
      for (int i = j; i < nf; ++i) cj[i] -= ljk * ck[i];
    }
    if (!(cj[j] > 1e-14 * scale)) return FastPath::kFailed;
    const double djj = std::sqrt(cj[j]);
    const double inv = 1.0 / djj;
    cj[j] = djj;
    rinv_(j) = inv;
    for (int i = j + 1; i < nf; ++i) cj[i] *= inv;
  }
  auto lsolve = [&](double* __restrict v) {  // v <- L⁻¹ v, two columns of L per sweep
    int i = 0;
    for (; i + 1 < nf; i += 2) {
      const double* __restrict ci = &Hf_(0, i);
      const double* __restrict ci1 = &Hf_(0, i + 1);
      const double vi = v[i] * rinv_(i);
      const double vi1 = (v[i + 1] - vi * ci[i + 1]) * rinv_(i + 1);
      v[i] = vi;
      v[i + 1] = vi1;
      for (int k = i + 2; k < nf; ++k) v[k] -= vi * ci[k] + vi1 * ci1[k];
    }
    if (i < nf) v[i] *= rinv_(i);
  };
  auto ltsolve = [&](double* __restrict v) {  // v <- L⁻ᵀ v, two columns of L per sweep (dots down them)
    int i = nf - 1;
    for (; i >= 1; i -= 2) {
      const double* __restrict ci = &Hf_(0, i);
      const double* __restrict ci1 = &Hf_(0, i - 1);
      double acc = 0.0, acc1 = 0.0;
      for (int k = i + 1; k < nf; ++k) {
        acc += ci[k] * v[k];
        acc1 += ci1[k] * v[k];
      }
      const double vi = (v[i] - acc) * rinv_(i);
      v[i] = vi;
      v[i - 1] = (v[i - 1] - acc1 - ci1[i] * vi) * rinv_(i - 1);
    }
    if (i == 0) {
      const double* __restrict c0 = &Hf_(0, 0);
      double acc = 0.0;
      for (int k = 1; k < nf; ++k) acc += c0[k] * v[k];
      v[0] = (v[0] - acc) * rinv_(0);
    }
  };
  // x0_F = −H_FF⁻¹ g_F'.
  for (int a = 0; a < nf; ++a) xf_(a) = -gf_(a);
  lsolve(xf_.data());
  ltsolve(xf_.data());
  if (qg > 0) {
    // Rows: N_F (qg x nf) with signs, rhs b' = b − N_B x_B − N_F x0_F.
    for (int r = 0; r < qg; ++r) {
      const int row = rows_[static_cast<size_t>(r)];
      const Active st = constraint_state_[static_cast<size_t>(row)];
      const double sg = st == Active::kUpper ? -1.0 : 1.0;
      const double bound = st == Active::kUpper ? ubA_(row) : lbA_(row);
      double rhs = sg * bound;
      if (any_bound) rhs -= sg * A_.row(row).dot(xb_);
      double* y = &Y_(0, r);
      for (int a = 0; a < nf; ++a) {
        const double v = sg * A_(row, free_[static_cast<size_t>(a)]);
        y[a] = v;
        rhs -= v * xf_(a);
      }
      rhs_(r) = rhs;
      lsolve(y);  // Y = L⁻¹ N_Fᵀ
    }
    // S = Yᵀ Y and its Cholesky (fails for dependent rows).
    for (int a = 0; a < qg; ++a) {
      for (int b = 0; b <= a; ++b) {
        const double* ya = &Y_(0, a);
        const double* yb = &Y_(0, b);
        double acc = 0.0;
        for (int k = 0; k < nf; ++k) acc += ya[k] * yb[k];
        S_(a, b) = acc;
      }
    }
    double sscale = 1e-300;
    for (int a = 0; a < qg; ++a) sscale = std::max(sscale, S_(a, a));
    for (int j = 0; j < qg; ++j) {
      double djj = S_(j, j);
      for (int k = 0; k < j; ++k) djj -= S_(j, k) * S_(j, k);
      if (!(djj > 1e-12 * sscale)) return FastPath::kFailed;
      djj = std::sqrt(djj);
      S_(j, j) = djj;
      for (int i = j + 1; i < qg; ++i) {
        double acc = S_(i, j);
        for (int k = 0; k < j; ++k) acc -= S_(i, k) * S_(j, k);
        S_(i, j) = acc / djj;
      }
    }
    for (int i = 0; i < qg; ++i) {
      double acc = rhs_(i);
      for (int k = 0; k < i; ++k) acc -= S_(i, k) * uf_(k);
      uf_(i) = acc / S_(i, i);
    }
    for (int i = qg - 1; i >= 0; --i) {
      double acc = uf_(i);
      for (int k = i + 1; k < qg; ++k) acc -= S_(k, i) * uf_(k);
      uf_(i) = acc / S_(i, i);
    }
    // x_F = x0_F + L⁻ᵀ Y u.
    tmp_.head(nf).setZero();
    for (int r = 0; r < qg; ++r) tmp_.head(nf) += uf_(r) * Y_.col(r).head(nf);
    ltsolve(tmp_.data());
    xf_.head(nf) += tmp_.head(nf);
  }
  if (any_bound) {
    x_ = xb_;
  }
  for (int a = 0; a < nf; ++a) x_(free_[static_cast<size_t>(a)]) = xf_(a);
  update_constraint_values();
  if (!is_feasible()) {
    double slack = 0.0, sign = 0.0;
    const int c = most_violated(&slack, &sign);
    if (c < 0) return FastPath::kFailed;
    *add = Entry{c, sign, false};
    return FastPath::kAdd;
  }
  // Multipliers: rows from u (sign by side); bounds from the gradient of the Lagrangian. The most
  // negative one (of an inequality) is the one to drop.
  const double tol = options_.dual_tolerance * std::max(1.0, g_.cwiseAbs().maxCoeff());
  double worst = -tol;
  *drop = -1;
  y_constraints_.setZero();
  for (int r = 0; r < qg; ++r) {
    const int row = rows_[static_cast<size_t>(r)];
    const Active st = constraint_state_[static_cast<size_t>(row)];
    if (st != Active::kEquality && uf_(r) < worst) {
      worst = uf_(r);
      *drop = row_entry_[static_cast<size_t>(r)];
    }
    y_constraints_(row) = st == Active::kUpper ? -uf_(r) : uf_(r);
  }
  y_bounds_.setZero();
  if (any_bound) {
    grad_.noalias() = H_ * x_;
    grad_ += g_;
    if (m_ > 0) grad_.noalias() -= A_.transpose() * y_constraints_;
    for (int i = 0; i < n_; ++i) {
      const Active st = bound_state_[static_cast<size_t>(i)];
      if (st == Active::kInactive) continue;
      y_bounds_(i) = grad_(i);
      const double u = st == Active::kLower ? grad_(i) : st == Active::kUpper ? -grad_(i) : 0.0;
      if (u < worst) {
        worst = u;
        *drop = bound_entry_[static_cast<size_t>(i)];
      }
    }
  }
  if (*drop >= 0) return FastPath::kDrop;
  active_ = W;
  return FastPath::kOptimal;
}

}  // namespace hpr::qp
