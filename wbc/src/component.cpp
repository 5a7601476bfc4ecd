#include "hpr/wbc/component.hpp"

#include <stdexcept>

namespace hpr::wbc {

WbcComponent::WbcComponent(const model::RobotSpec& robot, WbcConfig config, balance::PostureReferenceConfig posture,
                           int bad_state_ticks)
    : wbc_(robot, std::move(config)), reference_(robot, posture), bad_state_ticks_(bad_state_ticks) {
  damp_.resize(robot.model.nj);
  damp_.mode = JointCommand::Mode::kDamp;
  damp_.kd.setConstant(kDampGain);
  robot_state_.q.resize(robot.model.nq);
  robot_state_.v.resize(robot.model.nv);
}

void WbcComponent::reset() {
  reference_.reset();
  bad_state_count_ = 0;
}

void WbcComponent::damp(std::int64_t tick, Mode why, Outputs& out) const {
  out.command = damp_;
  out.command.tick = tick;
  out.mode = why;
}

bool WbcComponent::uses_wholebody(const EstimatedState& s) const {
  if (damping_ || !(reference_.started() || s.usable())) return false;
  return s.usable() || bad_state_count_ + 1 < bad_state_ticks_;
}

void WbcComponent::step(const Inputs& in, Outputs& out) {
  if (in.state == nullptr) throw std::invalid_argument("WbcComponent::step: no state");
  const EstimatedState& s = *in.state;
  if (!reference_.started()) {
    if (!s.usable()) return damp(s.tick, Mode::kDampNoState, out);
    reference_.start(s.q, s.time);
  }
  const balance::TaskReference& own = reference_.update(s.time, s.usable() ? &s : nullptr);
  if (damping_) return damp(s.tick, Mode::kDampOperator, out);
  bad_state_count_ = s.usable() ? 0 : bad_state_count_ + 1;
  if (bad_state_count_ >= bad_state_ticks_) return damp(s.tick, Mode::kDampBadState, out);
  robot_state_.tick = s.tick;
  robot_state_.time = s.time;
  robot_state_.q = s.q;
  robot_state_.v = s.v;
  const auto t0 = std::chrono::steady_clock::now();
  out.command = wbc_.step(robot_state_, in.wholebody != nullptr ? *in.wholebody : own);
  out.status = wbc_.status();
  out.status.compute_time_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  out.mode = Mode::kBalance;
}

}  // namespace hpr::wbc
