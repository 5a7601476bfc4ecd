// Checks and minimal repairs of a link's rotational inertia (hpr/model/urdf.hpp).
#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "hpr/model/urdf.hpp"

namespace hpr::model {

std::string check_inertia(const Matrix3d& I_c) {
  if (!I_c.allFinite()) return "has non-finite entries";
  if ((I_c - I_c.transpose()).cwiseAbs().maxCoeff() > 1e-12 * (1.0 + I_c.cwiseAbs().maxCoeff())) {
    return "is not symmetric";
  }
  const Eigen::SelfAdjointEigenSolver<Matrix3d> es(I_c);
  const Vector3d e = es.eigenvalues();  // ascending
  if (!(e(0) > 0.0)) {
    return fmt::format("is not positive definite (principal moments {:.3g}, {:.3g}, {:.3g})", e(0), e(1), e(2));
  }
  const double tol = 1e-9 * e(2);
  if (e(0) + e(1) < e(2) - tol) {
    return fmt::format("violates the triangle inequality (principal moments {:.6g} + {:.6g} < {:.6g})", e(0), e(1), e(2));
  }
  return "";
}

InertiaRepair regularise_inertia(double mass, const Matrix3d& I_c) {
  InertiaRepair out;
  out.I_c = I_c;
  if (!I_c.allFinite() || !std::isfinite(mass)) {
    out.error = "has non-finite entries";
    return out;
  }
  const Matrix3d I_sym = 0.5 * (I_c + I_c.transpose());
  if ((I_c - I_sym).cwiseAbs().maxCoeff() > 1e-12 * (1.0 + I_c.cwiseAbs().maxCoeff())) {
    out.error = "is not symmetric";
    return out;
  }
  const Eigen::SelfAdjointEigenSolver<Matrix3d> es(I_sym);
  const Vector3d e0 = es.eigenvalues();  // ascending
  Vector3d e = e0;
  constexpr double kNegativeTolerance = 1e-3, kTriangleTolerance = 0.10, kMinRadiusOfGyration = 0.002;
  const double scale = std::max(e(2), 0.0);
  std::vector<std::string> what;
  if (!(e(0) > 0.0)) {
    if (e(0) < -kNegativeTolerance * scale || (scale == 0.0 && e(0) < 0.0)) {
      out.error = fmt::format("is not positive definite (principal moments {:.3g}, {:.3g}, {:.3g})", e(0), e(1), e(2));
      return out;
    }
    const double floor = std::max(mass * kMinRadiusOfGyration * kMinRadiusOfGyration, 1e-6 * scale);
    const bool point = scale == 0.0;
    for (int k = 0; k < 3; ++k) e(k) = e(k) > 0.0 ? e(k) : floor;
    what.push_back(point ? fmt::format("point mass (zero inertia): given a radius of gyration of {:g} mm",
                                       1e3 * kMinRadiusOfGyration)
                         : fmt::format("principal moments {:.6g}, {:.6g}, {:.6g} are not all positive: raised to "
                                       "{:.6g} at least", e0(0), e0(1), e0(2), floor));
  }
  // Keep the moments ascending (with their axes) for the triangle inequality.
  Matrix3d V = es.eigenvectors();
  for (int a = 0; a < 2; ++a) {
    for (int b = 0; b < 2 - a; ++b) {
      if (e(b) > e(b + 1)) {
        std::swap(e(b), e(b + 1));
        V.col(b).swap(V.col(b + 1));
      }
    }
  }
  const double deficit = e(2) - e(0) - e(1);
  if (deficit > 1e-9 * e(2)) {
    if (deficit > kTriangleTolerance * e(2)) {
      out.error = fmt::format("violates the triangle inequality (principal moments {:.6g} + {:.6g} < {:.6g}, by "
                              "{:.1f} % of the largest)", e(0), e(1), e(2), 100.0 * deficit / e(2));
      return out;
    }
    const Vector3d before = e;
    e(0) += deficit / 3.0;
    e(1) += deficit / 3.0;
    e(2) -= deficit / 3.0;
    what.push_back(fmt::format("principal moments {:.6g}, {:.6g}, {:.6g} violate the triangle inequality by {:.2f} % "
                               "of the largest: moved to {:.6g}, {:.6g}, {:.6g}",
                               before(0), before(1), before(2), 100.0 * deficit / before(2), e(0), e(1), e(2)));
  }
  if (what.empty()) return out;
  out.I_c = V * e.asDiagonal() * V.transpose();
  out.I_c = 0.5 * (out.I_c + out.I_c.transpose()).eval();
  for (const auto& w : what) out.what += (out.what.empty() ? "" : "; ") + w;
  return out;
}

}  // namespace hpr::model
