// The solver's factorisation of the working set, kept between calls and updated by one constraint
// at a time (Givens rotations) as the working set changes: what makes a hot start cheap.
#include <Eigen/Cholesky>
#include <cmath>

#include "hpr/qp/qp_solver.hpp"

namespace hpr::qp {

namespace {

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

}  // namespace hpr::qp
