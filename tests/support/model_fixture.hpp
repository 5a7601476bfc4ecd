#pragma once
// Both robots, loaded from their configuration files, and random states within the joint limits.
#include <gtest/gtest.h>

#include <random>

#include "hpr/common/config.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/model/robot.hpp"
#include "process_group.hpp"

namespace hpr::test {

inline model::RobotSpec load_robot(const std::string& name) {
  const Config cfg = Config::load(source_dir() + "/config/" + name + ".yaml");
  return model::RobotSpec::load(cfg.section("robot"));
}

struct RandomState {
  explicit RandomState(unsigned seed) : gen(seed) {}
  std::mt19937 gen;
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(gen); }

  /// A configuration with the joints inside their limits (within 2 rad of zero for continuous ones).
  Eigen::VectorXd q(const model::Model& m) {
    Eigen::VectorXd q(m.nq);
    q.head<3>() = Eigen::Vector3d(uniform(-1, 1), uniform(-1, 1), uniform(0, 1.5));
    Eigen::Quaterniond quat(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
    quat.normalize();
    q(3) = quat.x();
    q(4) = quat.y();
    q(5) = quat.z();
    q(6) = quat.w();
    for (int j = 0; j < m.nj; ++j) {
      const double lo = std::max(m.q_lower[static_cast<size_t>(j)], -2.0);
      const double hi = std::min(m.q_upper[static_cast<size_t>(j)], 2.0);
      q(7 + j) = uniform(lo, hi);
    }
    return q;
  }
  Eigen::VectorXd v(const model::Model& m, double scale = 1.0) {
    Eigen::VectorXd v(m.nv);
    for (int k = 0; k < m.nv; ++k) v(k) = scale * uniform(-1, 1);
    return v;
  }
};

/// Relative difference ‖a − b‖ / max(1, ‖b‖).
inline double rel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / std::max(1.0, b.norm());
}

}  // namespace hpr::test
