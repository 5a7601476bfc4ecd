#include "hpr/node/freshness.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace hpr::node {

CommandFreshness::Verdict CommandFreshness::check(std::string_view source, std::int64_t utime, std::int64_t now_us, std::string& why) {
  if (window_us_ <= 0) return Verdict::kFresh;
  // As doubles: a forged utime may be anywhere in int64's range.
  const double age_s = (static_cast<double>(now_us) - static_cast<double>(utime)) * 1e-6;
  const double window_s = static_cast<double>(window_us_) * 1e-6;
  if (!(age_s <= window_s && age_s >= -window_s)) {
    why = age_s > 0 ? fmt::format("sent {:.3f} s ago by {} (a command is fresh for {:.3f} s): stale or replayed", age_s, source, window_s)
                    : fmt::format("dated {:.3f} s ahead of this host's clock by {} (at most {:.3f} s): the clocks disagree", -age_s,
                                  source, window_s);
    return Verdict::kStale;
  }
  const std::string key(source);
  if (const auto it = last_.find(key); it != last_.end()) {
    if (utime == it->second) return Verdict::kCopy;
    if (utime < it->second) {
      why = fmt::format("dated {:.6f} s before the last command taken from {}: replayed", static_cast<double>(it->second - utime) * 1e-6,
                        source);
      return Verdict::kReplayed;
    }
    it->second = utime;
    return Verdict::kFresh;
  }
  if (last_.size() >= kMaxSenders) {
    last_.erase(std::min_element(last_.begin(), last_.end(), [](const auto& a, const auto& b) { return a.second < b.second; }));
  }
  last_.emplace(key, utime);
  return Verdict::kFresh;
}

}  // namespace hpr::node
