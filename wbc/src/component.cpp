#include "hpr/wbc/component.hpp"


namespace hpr::wbc {

WbcComponent::WbcComponent(const model::RobotSpec& robot, WbcConfig config, int bad_state_ticks)
    : wbc_(robot, std::move(config)), bad_state_ticks_(bad_state_ticks) {
  damp_.resize(robot.model.nj);
  damp_.mode = JointCommand::Mode::kDamp;
  damp_.kd.setConstant(kDampGain);
  robot_state_.q.resize(robot.model.nq);
  robot_state_.v.resize(robot.model.nv);
}

void WbcComponent::reset() {
  bad_state_count_ = 0;
  had_wholebody_ = false;
  had_plan_ = false;
}

void WbcComponent::damp(const EstimatedState& s, Mode why, Outputs& out) const {
  out.command = damp_;
  out.command.tick = s.tick;
  out.command.time = s.time;
  out.mode = why;
}

WbcComponent::Mode WbcComponent::mode_for(const EstimatedState& s, bool planned) const {
  if (!planned) return Mode::kDampNoState;
  if (damping_) return Mode::kDampOperator;
  if (!s.usable() && bad_state_count_ + 1 >= bad_state_ticks_) return Mode::kDampBadState;
  return Mode::kBalance;
}

void WbcComponent::step(const Inputs& in, Outputs& out) {
  const EstimatedState& s = in.state;
  out.report.begin();
  const Mode mode = mode_for(s, in.plan.has_value());
  if (mode != Mode::kDampNoState) {
    if (mode != Mode::kDampOperator) bad_state_count_ = s.usable() ? 0 : bad_state_count_ + 1;
    if (mode == Mode::kBalance) {
      robot_state_.tick = s.tick;
      robot_state_.time = s.time;
      robot_state_.q = s.q;
      robot_state_.v = s.v;
      const auto t0 = std::chrono::steady_clock::now();
      out.command = wbc_.step(robot_state_, in.wholebody ? *in.wholebody : *in.plan);
      out.status = wbc_.status();
      out.status.compute_time_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
      out.mode = Mode::kBalance;
    }
  }
  if (mode != Mode::kBalance) damp(s, mode, out);
  report(s, in, out);
  had_wholebody_ = had_wholebody_ || in.wholebody.has_value();
  had_plan_ = had_plan_ || in.plan.has_value();
}

void WbcComponent::report(const EstimatedState& s, const Inputs& in, Outputs& out) const {
  StepReport& r = out.report;
  switch (out.mode) {
    case Mode::kDampNoState:
      if (had_plan_) {  // lost: the planner stopped
        r.outcome = StepOutcome::kDamping;
        r.raise("damping", "BALANCE_PLAN stale: no plan to follow");
      } else {
        r.outcome = StepOutcome::kNotReady;
        r.raise("damping", "no balance plan yet (ROBOT_STATE status {})", s.status);
      }
      return;
    case Mode::kDampOperator:
      r.outcome = StepOutcome::kDamping;
      r.raise("damping", "operator damp");
      return;
    case Mode::kDampBadState:
      r.outcome = StepOutcome::kDamping;
      r.raise("damping", "ROBOT_STATE flagged (status {}) for {} ticks", s.status, bad_state_count_);
      return;
    case Mode::kBalance:
      break;
  }
  r.clear("damping");
  r.set("contact_qp", out.status.qp_fallback, "contact QP failed: last valid wrenches kept");
  r.set("singular", out.status.singular, "task Jacobian singular (stretched knee): last valid inverse kept");
  if (in.wholebody) {
    r.clear("wholebody");
  } else if (had_wholebody_) {
    r.raise("wholebody", "WHOLEBODY_COMMAND stale: holding the reference posture");
  }
}

}  // namespace hpr::wbc
