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

WbcComponent::Mode WbcComponent::mode_for(const EstimatedState& s) const {
  if (!reference_.started() && !s.usable()) return Mode::kDampNoState;
  if (damping_) return Mode::kDampOperator;
  if (!s.usable() && bad_state_count_ + 1 >= bad_state_ticks_) return Mode::kDampBadState;
  return Mode::kBalance;
}

void WbcComponent::step(const Inputs& in, Outputs& out) {
  if (in.state == nullptr) throw std::invalid_argument("WbcComponent::step: no state");
  const EstimatedState& s = *in.state;
  const Mode mode = mode_for(s);
  if (mode == Mode::kDampNoState) return damp(s.tick, mode, out);
  if (!reference_.started()) reference_.start(s.q, s.time);
  const balance::TaskReference& own = reference_.update(s.time, s.usable() ? &s : nullptr);
  if (mode == Mode::kDampOperator) return damp(s.tick, mode, out);
  bad_state_count_ = s.usable() ? 0 : bad_state_count_ + 1;
  if (mode == Mode::kDampBadState) return damp(s.tick, mode, out);
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
