#include <fmt/format.h>

#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/estimator/node.hpp"

namespace hpr::estimator {

void TickReport::operator()(node::Runtime& rt, const Estimator& est, const StepReport& report, std::int64_t tick) {
  const std::string& reason = est.implausible_reason();
  const std::string_view kind = std::string_view(reason).substr(0, reason.find(':'));
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
  }
  last_kind_ = kind;
  rt.report(report);
}

}  // namespace hpr::estimator
