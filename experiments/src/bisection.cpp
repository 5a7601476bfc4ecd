#include "hpr/experiments/bisection.hpp"

#include <algorithm>

namespace hpr::experiments {

ImpulseBracket largest_recovered(const std::function<bool(double)>& recovered, double start, double max_impulse,
                                 double resolution) {
  ImpulseBracket b;
  double lo = 0.0, hi = 0.0, g = std::min(start, max_impulse);
  if (recovered(g)) {
    lo = g;
    // The largest push allowed next: a direction the robot withstands costs two trials, not the
    // whole ×1.5 ladder of full-length recovered runs up to it.
    if (g < max_impulse && !recovered(max_impulse)) hi = max_impulse;
    b.reached_max = hi == 0.0;
    while (!b.reached_max && g * 1.5 < hi) {
      g *= 1.5;
      if (!recovered(g)) {
        hi = g;
        break;
      }
      lo = g;
    }
  } else {
    hi = g;
    while (g > resolution) {
      g /= 1.5;
      if (recovered(g)) {
        lo = g;
        break;
      }
      hi = g;
    }
  }
  while (!b.reached_max && hi - lo > resolution) {
    const double mid = 0.5 * (lo + hi);
    if (recovered(mid)) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  if (b.reached_max) lo = max_impulse;
  b.max_recovered = lo;
  b.min_lost = b.reached_max ? 0.0 : hi;
  return b;
}

}  // namespace hpr::experiments
