#pragma once
/// \file
/// A recorded run as the viewer plays it: the shown channels' messages on the robot clock, sampled
/// into frames at a fixed rate (each frame holds the latest message of every channel at its time),
/// plus the time series of the plot panel.

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace hpr::viewer {

/// One message of a log, in log order.
struct LogEvent {
  std::int64_t timestamp_us = 0;  ///< when it was recorded (wall clock)
  std::string channel;
  std::vector<std::uint8_t> data;
};

class Timeline {
 public:
  /// Keeps the events of the shown channels (others are ignored), decodes each once to check it
  /// (a malformed one is skipped and counted in `skipped()`, its reason in `skip_reasons()`, one
  /// line per channel) and places every event on the robot clock: the `utime` of the latest
  /// ROBOT_STATE (or SIM_TRUTH, when there is no ROBOT_STATE) recorded up to it. Frames run from
  /// the first to the last of those times at `fps`. Throws std::invalid_argument when the log holds
  /// neither channel.
  Timeline(std::vector<LogEvent> events, double fps);

  [[nodiscard]] double fps() const { return fps_; }
  [[nodiscard]] double t0() const { return t0_; }            ///< robot clock of frame 0 [s]
  [[nodiscard]] double duration() const { return duration_; }  ///< [s]
  [[nodiscard]] int num_frames() const { return num_frames_; }
  [[nodiscard]] std::size_t num_events() const { return events_.size(); }
  [[nodiscard]] std::size_t skipped() const { return skipped_; }
  [[nodiscard]] const std::vector<std::string>& skip_reasons() const { return skip_reasons_; }

  /// Index of each channel's latest event at frame `i` (-1: none yet), in channels() order.
  [[nodiscard]] std::vector<long> events_at(int i) const;
  /// {"i", "t", "channels": {NAME: decoded JSON}} for frame `i` (clamped to the valid range).
  [[nodiscard]] nlohmann::json frame(int i) const;
  /// Decoded JSON of event `e` of channel index `c`, with its robot-clock time.
  [[nodiscard]] nlohmann::json event_json(std::size_t c, long e) const;
  [[nodiscard]] double event_time(std::size_t c, long e) const;
  /// {"t0", "duration", "fps", "num_frames", "skipped", "series": {"t": [...], "tau_ankle_V",
  /// "tau_hip_V", "l_ref_W", "l_cmd_W", "l_WCom": [[x, y, z], ...] per frame}} (null where a channel
  /// has not spoken yet). Push intervals under "pushes": [{"start", "end", "peak_N"}].
  [[nodiscard]] nlohmann::json summary() const;

 private:
  struct Event {
    double t;  ///< robot clock [s]
    std::size_t index;  ///< into events_
  };
  double fps_;
  double t0_ = 0, duration_ = 0;
  int num_frames_ = 0;
  std::size_t skipped_ = 0;
  std::vector<std::string> skip_reasons_;
  std::vector<LogEvent> events_;
  std::vector<std::vector<Event>> by_channel_;  ///< per channels() index, in time order
};

}  // namespace hpr::viewer
