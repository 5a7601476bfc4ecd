#pragma once
/// \file The estimator process's reporting (library hpr::estimator_node, shared with the composed
/// controllers): the HEALTH faults of a tick and the log of refused samples.

#include <cstdint>
#include <string>

#include "hpr/estimator/estimator.hpp"
#include "hpr/node/runtime.hpp"

namespace hpr::estimator {

/// Reports one estimator tick on `rt`: its report (Estimator::report: the faults "implausible",
/// "covariance" and "contact", not ready while it initialises) and the log of refused samples: a
/// refused sample is logged at once when its kind (the reason's text before ':') is new, else at
/// most once a second with a count of those not logged, so a fallen robot does not flood the log.
class TickReport {
 public:
  void operator()(node::Runtime& rt, const Estimator& est, const StepReport& report, std::int64_t tick);

 private:
  std::string last_kind_;
  double last_warn_ = -1e9;
  int unlogged_ = 0;
};

}  // namespace hpr::estimator
