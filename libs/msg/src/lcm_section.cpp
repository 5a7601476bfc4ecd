#include "hpr/msg/lcm_section.hpp"

namespace hpr::msg {

LcmSection LcmSection::load(const Config& cfg) {
  LcmSection o;
  if (!cfg.has("lcm")) return o;
  const Config l = cfg.section("lcm");
  o.url = l.string_or("url", "");
  o.channel_prefix = l.string_or("channel_prefix", "");
  o.health_rate_hz = l.real_or("health_rate_hz", o.health_rate_hz, 0.1, 1000.0);
  o.decode_fault_quiet_s = l.real_or("decode_fault_quiet_s", o.decode_fault_quiet_s, 0.0, 3600.0);
  o.tick_window = l.integer_or("tick_window", o.tick_window, 1, 1'000'000'000);
  o.source_quiet_s = l.real_or("source_quiet_s", o.source_quiet_s, 1e-3, 3600.0);
  o.tick_period_max_s = l.real_or("tick_period_max_s", o.tick_period_max_s, 1e-5, 10.0);
  o.time_slack_s = l.real_or("time_slack_s", o.time_slack_s, 0.0, 10.0);
  o.command_window_s = l.real_or("command_window_s", o.command_window_s, 0.0, 3600.0);
  o.spin_s = l.real_or("spin_s", o.spin_s, 0.0, 0.1);
  o.receive_direct = l.choice_or("receive", "liblcm", {"liblcm", "direct"}) == "direct";
  o.authenticate = l.choice_or("authentication", "required", {"required", "off"}) == "required";
  return o;
}

}  // namespace hpr::msg
