#pragma once
/// \file The largest impulse a push experiment recovers, by bracketing and bisection: the search
/// push_sweep runs per direction and push_tune per direction and candidate.

#include <functional>

namespace hpr::experiments {

struct ImpulseBracket {
  double max_recovered = 0.0;  ///< the largest impulse tried that was recovered [N s] (0: none)
  double min_lost = 0.0;       ///< the smallest impulse tried that was not (0 when reached_max)
  bool reached_max = false;    ///< the largest impulse allowed was recovered
};

/// `recovered(impulse)` runs one trial; recovery is taken to be monotonic in the impulse. `start`
/// first: when recovered, `max_impulse` next (recovered: done), then the impulse grows from `start`
/// by ×1.5 while recovered and below the failed maximum; when `start` is lost, it shrinks by ÷1.5
/// until recovered. Then bisection until the bracket is at most `resolution` wide. The trials run
/// in that order, one at a time.
ImpulseBracket largest_recovered(const std::function<bool(double)>& recovered, double start, double max_impulse,
                                 double resolution);

}  // namespace hpr::experiments
