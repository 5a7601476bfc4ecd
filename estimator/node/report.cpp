#include <fmt/format.h>

#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/estimator/node.hpp"

namespace hpr::estimator {

void TickReport::operator()(node::Runtime& rt, const Estimator& est, const EstimatedState& s, std::int64_t tick) {
  const std::string& reason = est.implausible_reason();
  const std::string kind = reason.substr(0, reason.find(':'));
  if (!reason.empty()) {
    const double now = monotonic_s();
    if (kind != last_kind_ || now - last_warn_ >= 1.0) {
      log::warn("sample {} refused: {}{}", tick, reason,
                unlogged_ > 0 ? fmt::format(" ({} more refused since the last message)", unlogged_) : "");
      last_warn_ = now;
      unlogged_ = 0;
    } else {
      ++unlogged_;
    }
    rt.set_fault("implausible", reason);
  } else {
    rt.clear_fault("implausible");
  }
  last_kind_ = kind;
  if ((s.status & kStatusCovariance) != 0) {
    rt.set_fault("covariance", fmt::format("position standard deviation {:.3f} m", est.position_std()));
  } else {
    rt.clear_fault("covariance");
  }
  if ((s.status & kStatusNoContact) != 0 && (s.status & kStatusInitialising) == 0) {
    rt.set_fault("contact", "no foot in contact");
  } else {
    rt.clear_fault("contact");
  }
  if ((s.status & kStatusInitialising) != 0) rt.report(node::StepOutcome::kNotReady);
}

}  // namespace hpr::estimator
