// loop_jitter: the machine's own 1 kHz wake-up latency, with nothing else in the loop: a
// PeriodicClock (absolute deadlines on the monotonic clock, the hal's clock) sleeping to each
// deadline with clock_nanosleep, measuring how late it wakes. Run it beside the stack, or alone
// with `chrt -f 80`, to tell the machine's scheduling latency from the stack's own.
//
//   loop_jitter [SECONDS] [PERIOD_S]      prints median, p99, p99.9 and max lateness [us]
#include <time.h>

#include <cstdio>
#include <cstdlib>
#include <vector>

#include "hpr/common/stats.hpp"
#include "hpr/common/time.hpp"

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
  const double period = argc > 2 ? std::atof(argv[2]) : 1e-3;
  if (!(seconds > 0) || !(period > 0)) {
    std::fprintf(stderr, "usage: loop_jitter [SECONDS] [PERIOD_S]\n");
    return 2;
  }
  const auto n = static_cast<std::size_t>(seconds / period);
  std::vector<double> late;
  late.reserve(n);
  hpr::PeriodicClock clock(period);
  clock.next();
  for (std::size_t i = 0; i < n; ++i) {
    const auto deadline_ns = static_cast<long long>(clock.deadline() * 1e9);
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(deadline_ns / 1000000000LL);
    ts.tv_nsec = static_cast<long>(deadline_ns % 1000000000LL);
    // The steady clock is CLOCK_MONOTONIC on Linux.
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
    late.push_back(clock.next(1e9));
  }
  std::printf("loop_jitter: %zu periods of %.3f ms: lateness median %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us\n", n, period * 1e3,
              hpr::percentile(late, 0.5) * 1e6, hpr::percentile(late, 0.99) * 1e6, hpr::percentile(late, 0.999) * 1e6,
              hpr::percentile(late, 1.0) * 1e6);
  return 0;
}
