#include "hpr/viewer/timeline.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include <fmt/format.h>

#include "hpr/msg/channels.hpp"
#include "hpr/viewer/channels.hpp"

namespace hpr::viewer {

Timeline::Timeline(std::vector<LogEvent> events, double fps) : fps_(fps) {
  if (!(fps > 0.0 && fps <= 1000.0)) throw std::invalid_argument(fmt::format("frame rate {} is not in (0, 1000]", fps));
  const auto& chans = channels();
  by_channel_.resize(chans.size());
  const int clock_channels[2] = {channel_index(hpr::msg::channels::kRobotState.name), channel_index(hpr::msg::channels::kSimTruth.name)};
  // The clock: ROBOT_STATE when the log has it, else SIM_TRUTH.
  int clock = -1;
  for (int c : clock_channels) {
    if (clock >= 0) break;
    for (const auto& e : events) {
      if (e.channel == chans[static_cast<std::size_t>(c)].name) {
        clock = c;
        break;
      }
    }
  }
  if (clock < 0) throw std::invalid_argument("the log has neither ROBOT_STATE nor SIM_TRUTH: nothing to place the robot by");

  std::set<std::string> reported;
  bool started = false;
  double now = 0.0;
  std::vector<std::size_t> pending;  // events before the first clock message: placed at its time
  for (auto& e : events) {
    const int c = channel_index(e.channel);
    if (c < 0) continue;
    Decoded d;
    try {
      d = decode(e.channel, e.data.data(), e.data.size());
    } catch (const DecodeError& err) {
      ++skipped_;
      if (reported.insert(e.channel).second) skip_reasons_.push_back(err.what());
      continue;
    }
    if (c == clock) {
      const double t = static_cast<double>(d.utime) * 1e-6;
      if (!started) {
        started = true;
        now = t;
        t0_ = t;
        for (std::size_t p : pending) {
          by_channel_[static_cast<std::size_t>(channel_index(events_[p].channel))].push_back({now, p});
        }
        pending.clear();
      }
      now = std::max(now, t);  // a clock that steps back (a restarted source) does not reorder the log
    }
    const std::size_t index = events_.size();
    events_.push_back(std::move(e));
    if (started) {
      by_channel_[static_cast<std::size_t>(c)].push_back({now, index});
    } else {
      pending.push_back(index);
    }
  }
  duration_ = now - t0_;
  num_frames_ = static_cast<int>(std::floor(duration_ * fps_ + 1e-9)) + 1;
}

std::vector<long> Timeline::events_at(int i) const {
  i = std::clamp(i, 0, num_frames_ - 1);
  const double t = t0_ + i / fps_ + 1e-9;
  std::vector<long> out(by_channel_.size(), -1);
  for (std::size_t c = 0; c < by_channel_.size(); ++c) {
    const auto& v = by_channel_[c];
    const auto it = std::upper_bound(v.begin(), v.end(), t, [](double x, const Event& e) { return x < e.t; });
    out[c] = static_cast<long>(it - v.begin()) - 1;
  }
  return out;
}

nlohmann::json Timeline::event_json(std::size_t c, long e) const {
  const auto& ev = events_[by_channel_[c][static_cast<std::size_t>(e)].index];
  return decode(ev.channel, ev.data.data(), ev.data.size()).json;
}

double Timeline::event_time(std::size_t c, long e) const { return by_channel_[c][static_cast<std::size_t>(e)].t; }

nlohmann::json Timeline::frame(int i) const {
  i = std::clamp(i, 0, num_frames_ - 1);
  nlohmann::json chans = nlohmann::json::object();
  const auto at = events_at(i);
  for (std::size_t c = 0; c < at.size(); ++c) {
    if (at[c] >= 0) chans[channels()[c].name] = event_json(c, at[c]);
  }
  return {{"i", i}, {"t", t0_ + i / fps_}, {"channels", chans}};
}

nlohmann::json Timeline::summary() const {
  using nlohmann::json;
  const std::size_t balance = static_cast<std::size_t>(channel_index(hpr::msg::channels::kBalanceStatus.name));
  const std::size_t cam = static_cast<std::size_t>(channel_index(hpr::msg::channels::kCamReference.name));
  const std::size_t wb = static_cast<std::size_t>(channel_index(hpr::msg::channels::kWholebodyCommand.name));
  const std::size_t state = static_cast<std::size_t>(channel_index(hpr::msg::channels::kRobotState.name));
  const std::size_t truth = static_cast<std::size_t>(channel_index(hpr::msg::channels::kSimTruth.name));
  json t = json::array(), ankle = json::array(), hip = json::array(), lref = json::array(), lcmd = json::array(),
       lmeas = json::array();
  // Decoding each frame's messages again would cost seconds on a long log; the series need a few
  // fields, read from the same JSON once per distinct event.
  std::vector<long> last(by_channel_.size(), -2);
  std::vector<json> cache(by_channel_.size());
  auto field = [&](std::size_t c, long e, const char* name) -> json {
    if (e < 0) return nullptr;
    if (last[c] != e) {
      cache[c] = event_json(c, e);
      last[c] = e;
    }
    return cache[c][name];
  };
  for (int i = 0; i < num_frames_; ++i) {
    const auto at = events_at(i);
    t.push_back(t0_ + i / fps_);
    ankle.push_back(field(balance, at[balance], "tau_ankle_V"));
    hip.push_back(field(balance, at[balance], "tau_hip_V"));
    lref.push_back(field(cam, at[cam], "l_ref_W"));
    lcmd.push_back(field(wb, at[wb], "l_cmd_W"));
    lmeas.push_back(field(state, at[state], "l_WCom"));
  }
  // Pushes from the simulator's truth: intervals where a force is applied.
  json pushes = json::array();
  {
    const auto& v = by_channel_[truth];
    double start = -1, peak = 0;
    for (std::size_t k = 0; k < v.size(); ++k) {
      const auto j = event_json(truth, static_cast<long>(k));
      const bool active = j["push_active"].get<bool>();
      if (active) {
        if (start < 0) start = v[k].t;
        double f2 = 0;
        for (const auto& x : j["push_force_W"]) f2 += x.is_number() ? x.get<double>() * x.get<double>() : 0.0;
        peak = std::max(peak, std::sqrt(f2));
      }
      if ((!active || k + 1 == v.size()) && start >= 0) {
        pushes.push_back({{"start", start}, {"end", v[k].t}, {"peak_N", peak}});
        start = -1;
        peak = 0;
      }
    }
  }
  return {{"t0", t0_},
          {"duration", duration_},
          {"fps", fps_},
          {"num_frames", num_frames_},
          {"skipped", skipped_},
          {"skip_reasons", skip_reasons_},
          {"pushes", pushes},
          {"series", {{"t", t}, {"tau_ankle_V", ankle}, {"tau_hip_V", hip}, {"l_ref_W", lref}, {"l_cmd_W", lcmd}, {"l_WCom", lmeas}}}};
}

}  // namespace hpr::viewer
