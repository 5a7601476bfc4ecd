#pragma once
// The fixed-size arrays of the LCM messages and the Eigen vectors of the ports (private to hpr::msg).
#include <Eigen/Core>
#include <cmath>

namespace hpr::msg::detail {

inline bool finite(const double* v, int n) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}
template <int N>
void put(const Eigen::Matrix<double, N, 1>& v, double* dst) {
  for (int k = 0; k < N; ++k) dst[k] = v(k);
}
template <int N>
Eigen::Matrix<double, N, 1> get(const double* src) {
  return Eigen::Map<const Eigen::Matrix<double, N, 1>>(src);
}

}  // namespace hpr::msg::detail
