#include "hpr/hal/mit_codec.hpp"

#include <algorithm>
#include <cmath>

namespace hpr::hal {

std::uint32_t to_uint(double x, double lo, double hi, int bits) {
  const double span = hi - lo;
  const double top = static_cast<double>((1U << bits) - 1U);
  if (!std::isfinite(x)) x = x > 0 ? hi : lo;  // NaN maps to lo; callers reject non-finite first
  const double u = std::round((std::clamp(x, lo, hi) - lo) * top / span);
  return static_cast<std::uint32_t>(std::clamp(u, 0.0, top));
}

double from_uint(std::uint32_t u, double lo, double hi, int bits) {
  const double top = static_cast<double>((1U << bits) - 1U);
  return lo + static_cast<double>(u) * (hi - lo) / top;
}

CanFrame MitCodec::encode_command(int drive_id, const DriveCommand& c, const DriveLimits& l) const {
  const std::uint32_t p = to_uint(c.p_des, l.p_min, l.p_max, 16);
  const std::uint32_t v = to_uint(c.v_des, l.v_min, l.v_max, 12);
  const std::uint32_t kp = to_uint(c.kp, l.kp_min, l.kp_max, 12);
  const std::uint32_t kd = to_uint(c.kd, l.kd_min, l.kd_max, 12);
  const std::uint32_t t = to_uint(c.t_ff, l.t_min, l.t_max, 12);
  CanFrame f;
  f.id = static_cast<std::uint32_t>(drive_id);
  f.len = 8;
  auto& d = f.data;
  d[0] = static_cast<std::uint8_t>(p >> 8);
  d[1] = static_cast<std::uint8_t>(p & 0xFF);
  d[2] = static_cast<std::uint8_t>(v >> 4);
  d[3] = static_cast<std::uint8_t>(((v & 0xF) << 4) | (kp >> 8));
  d[4] = static_cast<std::uint8_t>(kp & 0xFF);
  d[5] = static_cast<std::uint8_t>(kd >> 4);
  d[6] = static_cast<std::uint8_t>(((kd & 0xF) << 4) | (t >> 8));
  d[7] = static_cast<std::uint8_t>(t & 0xFF);
  return f;
}

CanFrame MitCodec::encode_special(int drive_id, SpecialCommand s) const {
  CanFrame f;
  f.id = static_cast<std::uint32_t>(drive_id);
  f.len = 8;
  for (int i = 0; i < 7; ++i) f.data[static_cast<std::size_t>(i)] = 0xFF;
  f.data[7] = static_cast<std::uint8_t>(s);
  return f;
}

std::optional<DriveReply> MitCodec::decode_reply(const CanFrame& f, const DriveLimits& l) const {
  if ((f.id & (kCanErrFlag | kCanRtrFlag | kCanEffFlag)) != 0 || f.len != 8) return std::nullopt;
  const auto& d = f.data;
  DriveReply r;
  r.drive_id = d[0];
  if (f.id != reply_id(r.drive_id)) return std::nullopt;
  const std::uint32_t p = (static_cast<std::uint32_t>(d[1]) << 8) | d[2];
  const std::uint32_t v = (static_cast<std::uint32_t>(d[3]) << 4) | (d[4] >> 4);
  const std::uint32_t t = ((static_cast<std::uint32_t>(d[4]) & 0xF) << 8) | d[5];
  r.p = from_uint(p, l.p_min, l.p_max, 16);
  r.v = from_uint(v, l.v_min, l.v_max, 12);
  r.t = from_uint(t, l.t_min, l.t_max, 12);
  r.fault = d[6];
  r.temperature = static_cast<double>(d[7]) - 40.0;
  return r;
}

CanFrame MitCodec::encode_reply(const DriveReply& r, const DriveLimits& l) const {
  const std::uint32_t p = to_uint(r.p, l.p_min, l.p_max, 16);
  const std::uint32_t v = to_uint(r.v, l.v_min, l.v_max, 12);
  const std::uint32_t t = to_uint(r.t, l.t_min, l.t_max, 12);
  CanFrame f;
  f.id = reply_id(r.drive_id);
  f.len = 8;
  auto& d = f.data;
  d[0] = static_cast<std::uint8_t>(r.drive_id);
  d[1] = static_cast<std::uint8_t>(p >> 8);
  d[2] = static_cast<std::uint8_t>(p & 0xFF);
  d[3] = static_cast<std::uint8_t>(v >> 4);
  d[4] = static_cast<std::uint8_t>(((v & 0xF) << 4) | (t >> 8));
  d[5] = static_cast<std::uint8_t>(t & 0xFF);
  d[6] = r.fault;
  d[7] = static_cast<std::uint8_t>(std::clamp(std::lround(r.temperature + 40.0), 0L, 255L));
  return f;
}

std::optional<DriveCodec::Request> MitCodec::decode_request(const CanFrame& f, const DriveLimits& l) const {
  if ((f.id & (kCanErrFlag | kCanRtrFlag | kCanEffFlag)) != 0 || f.len != 8) return std::nullopt;
  if (f.id < 1 || f.id > static_cast<std::uint32_t>(kMaxDriveId)) return std::nullopt;
  Request r;
  r.drive_id = static_cast<int>(f.id);
  const auto& d = f.data;
  if (std::all_of(d.begin(), d.begin() + 7, [](std::uint8_t b) { return b == 0xFF; }) && d[7] >= 0xFC && d[7] <= 0xFE) {
    r.special = static_cast<SpecialCommand>(d[7]);
    return r;
  }
  const std::uint32_t p = (static_cast<std::uint32_t>(d[0]) << 8) | d[1];
  const std::uint32_t v = (static_cast<std::uint32_t>(d[2]) << 4) | (d[3] >> 4);
  const std::uint32_t kp = ((static_cast<std::uint32_t>(d[3]) & 0xF) << 8) | d[4];
  const std::uint32_t kd = (static_cast<std::uint32_t>(d[5]) << 4) | (d[6] >> 4);
  const std::uint32_t t = ((static_cast<std::uint32_t>(d[6]) & 0xF) << 8) | d[7];
  DriveCommand c;
  c.p_des = from_uint(p, l.p_min, l.p_max, 16);
  c.v_des = from_uint(v, l.v_min, l.v_max, 12);
  c.kp = from_uint(kp, l.kp_min, l.kp_max, 12);
  c.kd = from_uint(kd, l.kd_min, l.kd_max, 12);
  c.t_ff = from_uint(t, l.t_min, l.t_max, 12);
  r.command = c;
  return r;
}

CanFrame encode_int16s(std::uint32_t id, const double* values, int count, double scale) {
  CanFrame f;
  f.id = id;
  f.len = 8;
  for (int i = 0; i < count; ++i) {
    const double x = std::isfinite(values[i]) ? values[i] / scale : 0.0;
    const auto v = static_cast<std::int16_t>(std::clamp(std::round(x), -32767.0, 32767.0));
    const auto u = static_cast<std::uint16_t>(v);
    f.data[static_cast<std::size_t>(2 * i)] = static_cast<std::uint8_t>(u >> 8);
    f.data[static_cast<std::size_t>(2 * i + 1)] = static_cast<std::uint8_t>(u & 0xFF);
  }
  return f;
}

bool decode_int16s(const CanFrame& f, double* values, int count, double scale) {
  if (f.len < 2 * count || (f.id & kCanErrFlag) != 0) return false;
  for (int i = 0; i < count; ++i) {
    const auto u = static_cast<std::uint16_t>((f.data[static_cast<std::size_t>(2 * i)] << 8) |
                                              f.data[static_cast<std::size_t>(2 * i + 1)]);
    values[i] = static_cast<double>(static_cast<std::int16_t>(u)) * scale;
  }
  return true;
}

CanFrame encode_lockstep_tick(std::int64_t tick) {
  CanFrame f;
  f.id = kLockstepTickId;
  f.len = 8;
  const auto u = static_cast<std::uint64_t>(tick);
  for (std::size_t i = 0; i < 8; ++i) f.data[i] = static_cast<std::uint8_t>(u >> (56 - 8 * i));
  return f;
}

std::optional<std::int64_t> decode_lockstep_tick(const CanFrame& f) {
  if (f.len != 8 || (f.id & kCanErrFlag) != 0) return std::nullopt;
  std::uint64_t u = 0;
  for (std::size_t i = 0; i < 8; ++i) u = (u << 8) | f.data[i];
  return static_cast<std::int64_t>(u);
}

}  // namespace hpr::hal
