#include "hpr/planner/component.hpp"

namespace hpr::planner {

BalancePlanner::BalancePlanner(const model::RobotSpec& robot, balance::PostureReferenceConfig config)
    : reference_(robot, std::move(config)) {}

void BalancePlanner::step(const Inputs& in, Outputs& out) {
  const EstimatedState& s = in.state;
  out.report.begin();
  if (!reference_.started()) {
    if (!s.usable()) {
      out.valid = false;
      out.report.outcome = StepOutcome::kNotReady;
      return;
    }
    reference_.start(s.q, s.time);
  }
  out.plan.tick = s.tick;
  out.plan.reference = reference_.update(s.time, s.usable() ? &s : nullptr);
  out.plan.stage = reference_.stage();
  out.plan.f_ext_W = reference_.external_force();
  out.valid = true;
}

}  // namespace hpr::planner
