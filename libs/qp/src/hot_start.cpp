// The hot start: the previous call's working set tried first on the new problem, by a Schur
// complement on the free variables, before the active-set iterations (qp_solver.cpp).
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

#include "hpr/qp/qp_solver.hpp"

namespace hpr::qp {

Solver::FastPath Solver::try_working_set(const std::vector<Entry>& W, Entry* add, int* drop) {
  // Bounds in W fix their variables; the rows of W are handled by a Schur complement on the free
  // variables: H_FF x_F + g_F' = N_Fᵀ u, N_F x_F = b'.
  bool any_bound = false;
  if (!load_working_set(W, &any_bound)) return FastPath::kFailed;
  const int nf = static_cast<int>(free_.size()), qg = static_cast<int>(rows_.size());
  if (qg > nf) return FastPath::kFailed;
  reduce_to_free(any_bound);
  if (!factor_free_hessian()) return FastPath::kFailed;
  // x0_F = −H_FF⁻¹ g_F'.
  for (int a = 0; a < nf; ++a) xf_(a) = -gf_(a);
  lsolve_free(xf_.data());
  ltsolve_free(xf_.data());
  if (qg > 0 && !solve_rows(any_bound)) return FastPath::kFailed;
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
  const FastPath f = multipliers(any_bound, drop);
  if (f == FastPath::kOptimal) active_ = W;
  return f;
}

bool Solver::load_working_set(const std::vector<Entry>& W, bool* any_bound) {
  free_.clear();
  rows_.clear();
  row_entry_.clear();
  std::fill(bound_state_.begin(), bound_state_.end(), Active::kInactive);
  std::fill(constraint_state_.begin(), constraint_state_.end(), Active::kInactive);
  for (std::size_t w = 0; w < W.size(); ++w) {
    const Entry& e = W[w];
    const bool eq = lower(e.c) == upper(e.c);
    const double bound = e.sign > 0 ? lower(e.c) : upper(e.c);
    if (!std::isfinite(bound)) return false;
    const Active st = eq ? Active::kEquality : (e.sign > 0 ? Active::kLower : Active::kUpper);
    if (e.c < n_) {
      if (!*any_bound) xb_.setZero();
      *any_bound = true;
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
    if (lb_(i) == ub_(i) && bound_state_[static_cast<size_t>(i)] == Active::kInactive) return false;
  }
  for (int j = 0; j < m_; ++j) {
    if (lbA_(j) == ubA_(j) && constraint_state_[static_cast<size_t>(j)] == Active::kInactive) return false;
  }
  for (int i = 0; i < n_; ++i) {
    if (bound_state_[static_cast<size_t>(i)] == Active::kInactive) free_.push_back(i);
  }
  return true;
}

void Solver::reduce_to_free(bool any_bound) {
  const int nf = static_cast<int>(free_.size());
  if (any_bound) {
    grad_.noalias() = H_ * xb_;
  }
  if (nf == n_) {  // no bound in W: H_FF = H (one vectorised copy)
    Hf_ = H_;
    gf_ = g_;
    return;
  }
  for (int a = 0; a < nf; ++a) {
    const int ia = free_[static_cast<size_t>(a)];
    gf_(a) = any_bound ? g_(ia) + grad_(ia) : g_(ia);
    for (int b = a; b < nf; ++b) Hf_(b, a) = H_(free_[static_cast<size_t>(b)], ia);
  }
}

bool Solver::factor_free_hessian() {
  // Cholesky of H_FF, left-looking so that every inner loop runs down a contiguous column (the
  // lower triangle of Hf_ is column-major): L(j:, j) = (H(j:, j) − Σ_k L(j, k) L(j:, k)) / L_jj.
  // rinv_ holds 1 / L_jj.
  const int nf = static_cast<int>(free_.size());
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
    if (!(cj[j] > 1e-14 * scale)) return false;
    const double djj = std::sqrt(cj[j]);
    const double inv = 1.0 / djj;
    cj[j] = djj;
    rinv_(j) = inv;
    for (int i = j + 1; i < nf; ++i) cj[i] *= inv;
  }
  return true;
}

void Solver::lsolve_free(double* __restrict v) const {  // two columns of L per sweep
  const int nf = static_cast<int>(free_.size());
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
}

void Solver::ltsolve_free(double* __restrict v) const {  // two columns of L per sweep (dots down them)
  const int nf = static_cast<int>(free_.size());
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
}

bool Solver::solve_rows(bool any_bound) {
  const int nf = static_cast<int>(free_.size()), qg = static_cast<int>(rows_.size());
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
    lsolve_free(y);  // Y = L⁻¹ N_Fᵀ
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
    if (!(djj > 1e-12 * sscale)) return false;
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
  ltsolve_free(tmp_.data());
  xf_.head(nf) += tmp_.head(nf);
  return true;
}

Solver::FastPath Solver::multipliers(bool any_bound, int* drop) {
  // Rows from u (sign by side); bounds from the gradient of the Lagrangian. The most negative one
  // (of an inequality) is the one to drop.
  const int qg = static_cast<int>(rows_.size());
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
  return *drop >= 0 ? FastPath::kDrop : FastPath::kOptimal;
}

}  // namespace hpr::qp
