#include "hpr/msg/ticks.hpp"

#include "hpr/msg/channels.hpp"

#include <fmt/format.h>

namespace hpr::msg {

std::int64_t tick_of(const void* data, int size) {
  if (data == nullptr || size < 16) return -1;
  const auto* b = static_cast<const std::uint8_t*>(data) + 8;
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | b[i];  // LCM encodes big-endian
  return static_cast<std::int64_t>(v);
}

int flow_rank(const std::string& channel) {
  static const std::map<std::string, int> k = {
      {channels::kRobotSensors.name, 0},     {channels::kRobotState.name, 1},   {channels::kBalancePlan.name, 2},
      {channels::kCamReference.name, 3},     {channels::kWholebodyCommand.name, 4}, {channels::kJointCommand.name, 5},
      {channels::kBalanceStatus.name, 6},    {channels::kSimTruth.name, 7}};
  const auto it = k.find(channel);
  return it == k.end() ? kNotInFlow : it->second;
}

void TickCoverage::add(const std::string& channel, std::int64_t tick) {
  if (tick < 0 || flow_rank(channel) == kNotInFlow) return;
  auto [it, fresh] = seen_.try_emplace(channel);
  Seen& s = it->second;
  if (fresh) s.first = tick;
  if (tick < s.first) {  // an earlier tick arrived late: shift the bits
    s.bits.insert(s.bits.begin(), static_cast<std::size_t>(s.first - tick), false);
    s.first = tick;
  }
  const auto i = static_cast<std::size_t>(tick - s.first);
  if (i >= s.bits.size()) s.bits.resize(i + 1, false);
  s.bits[i] = true;
}

std::map<std::string, std::vector<std::int64_t>> TickCoverage::lacking() const {
  std::map<std::string, std::vector<std::int64_t>> out;
  for (const auto& [channel, s] : seen_) {
    for (std::size_t i = 0; i < s.bits.size(); ++i) {
      if (!s.bits[i]) out[channel].push_back(s.first + static_cast<std::int64_t>(i));
    }
  }
  return out;
}

std::string tick_ranges(const std::vector<std::int64_t>& ticks, std::size_t limit) {
  std::string out;
  std::size_t ranges = 0;
  for (std::size_t i = 0; i < ticks.size(); ++ranges) {
    std::size_t j = i;
    while (j + 1 < ticks.size() && ticks[j + 1] == ticks[j] + 1) ++j;
    if (ranges > 0) out += ", ";
    if (ranges == limit) return out + "...";
    out += j == i ? std::to_string(ticks[i]) : fmt::format("{}-{}", ticks[i], ticks[j]);
    i = j + 1;
  }
  return out;
}

}  // namespace hpr::msg
