// The active-set iterations: the dual method from the unconstrained minimiser (a cold start) and
// the primal method from a feasible working set (after a hot start), each adding or dropping one
// constraint per iteration through the factorisation (factorization.cpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include "internal.hpp"
#include "hpr/qp/qp_solver.hpp"

namespace hpr::qp {

using detail::kInf;

Status Solver::run_dual() {
  int refinements = 0;
  while (true) {
    detail::mark(active_, n_, bound_state_, constraint_state_);
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
      detail::mark(active_, n_, bound_state_, constraint_state_);
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
      detail::mark(active_, n_, bound_state_, constraint_state_);
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
      detail::mark(active_, n_, bound_state_, constraint_state_);
    }
    ++changes_;
    if (changes_ >= options_.max_working_set_changes) return Status::kIterationLimit;
  }
}

Status Solver::solve(bool hot, const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb,
                     const ConstVector& ub, const ConstVector& lbA, const ConstVector& ubA) {
  changes_ = 0;
  have_best_ = false;
  Status v = validate(H, g, A, lb, ub, lbA, ubA);
  if (v == Status::kOptimal) v = take_data(H, g, A, lb, ub, lbA, ubA);
  if (v != Status::kOptimal) {
    finish(v);
    return v;
  }
  if (hot && have_previous_ && hot_start_fast_path()) return status_;
  if (!start_working_set(hot)) {
    finish(Status::kNotPositiveDefinite);
    return status_;
  }
  finish(iterate());
  return status_;
}

Status Solver::take_data(const ConstMatrix& H, const ConstVector& g, const ConstMatrix& A, const ConstVector& lb, const ConstVector& ub,
                         const ConstVector& lbA, const ConstVector& ubA) {
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
    return !std::isfinite(sum) ? Status::kNonFinite : Status::kNotPositiveDefinite;
  }
  if (!same_H) H_factorized_ = false;
  g_ = g;
  lb_ = lb;
  ub_ = ub;
  lbA_ = lbA;
  ubA_ = ubA;
  kkt_current_ = objective_current_ = false;
  row_norms_current_ = false;
  return Status::kOptimal;
}

bool Solver::hot_start_fast_path() {
  // Most hot starts keep their working set; solve it directly and accept a KKT point. When the data
  // moved a constraint in or out, a few single changes of the working set, each solved the same
  // way, usually reach the KKT point at a fraction of a refactorisation.
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
      return true;
    }
    if (r == FastPath::kFailed) break;
    if (r == FastPath::kAdd) {
      if (static_cast<int>(trial_.size()) >= n_) break;
      trial_.push_back(add);
    } else {
      trial_.erase(trial_.begin() + drop);
    }
  }
  return false;
}

bool Solver::start_working_set(bool hot) {
  if (!H_factorized_) {
    H_factorized_ = factorize();
    if (!H_factorized_) return false;
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
  detail::mark(active_, n_, bound_state_, constraint_state_);
  return true;
}

int Solver::most_negative_multiplier() const {
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
}

Status Solver::iterate() {
  while (true) {
    const bool feasible = is_feasible();
    const int worst = most_negative_multiplier();
    if (feasible) {
      consider_candidate();
      return worst < 0 ? Status::kOptimal : run_primal();
    }
    if (worst < 0) return run_dual();
    // Neither feasible nor dual feasible: drop the most negative multiplier and re-solve.
    drop_from_factorization(worst);
    ++changes_;
    solve_working_set();
    detail::mark(active_, n_, bound_state_, constraint_state_);
    if (changes_ >= options_.max_working_set_changes) return Status::kIterationLimit;
  }
}

}  // namespace hpr::qp
