#include "hpr/balance/force_observer.hpp"

#include <algorithm>

namespace hpr::balance {

void ExternalForceObserver::update(double t, const Eigen::Vector2d& v_com, const Eigen::Vector2d& f_ground) {
  const double dt = t - t_prev_;
  const bool running = t_prev_ >= 0.0 && dt > 0.0 && dt < kMaxGap;
  if (running) {
    momentum_integral_ += (f_ground + f_ext_) * dt;
    f_ext_ = (config_.mass * (v_com - v_prev_) - momentum_integral_) / config_.time_constant;
  }
  // The start, and the restart after a sensor's NaN (the compensation with it).
  if (!running || !f_ext_.allFinite()) {
    if (!f_ext_.allFinite()) f_comp_.setZero();
    v_prev_ = v_com;
    momentum_integral_.setZero();
    f_ext_.setZero();
  } else if (config_.compensate) {
    f_comp_ += std::min(1.0, dt / config_.compensation_filter) * (f_ext_ - f_comp_);
    const double n = f_comp_.norm();
    if (n > config_.max_force) f_comp_ *= config_.max_force / n;
  }
  // When the push began: |F̂| last rose above push_onset (a restart above sets F̂ to zero).
  if (f_ext_.norm() < config_.push_onset) {
    push_start_ = -1.0;
  } else if (push_start_ < 0.0) {
    push_start_ = t;
  }
  t_prev_ = t;
}

void ExternalForceObserver::restart() {
  t_prev_ = -1.0;
  f_ext_.setZero();
  f_comp_.setZero();
  push_start_ = -1.0;
  momentum_integral_.setZero();
}

}  // namespace hpr::balance
