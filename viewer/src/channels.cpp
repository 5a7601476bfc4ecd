#include "hpr/viewer/channels.hpp"

#include <cmath>
#include <functional>

#include <fmt/format.h>

#include "hpr/msg/channels.hpp"

namespace hpr::viewer {
namespace {

using nlohmann::json;

json num(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

template <std::size_t N>
json arr(const double (&a)[N]) {
  json j = json::array();
  for (double x : a) j.push_back(num(x));
  return j;
}
json arr(const std::vector<double>& a) {
  json j = json::array();
  for (double x : a) j.push_back(num(x));
  return j;
}
json arr2(const std::vector<std::vector<double>>& a) {
  json j = json::array();
  for (const auto& row : a) j.push_back(arr(row));
  return j;
}
json flags(const std::vector<int8_t>& a) {
  json j = json::array();
  for (int8_t x : a) j.push_back(x != 0);
  return j;
}
template <std::size_t N>
json ints(const int8_t (&a)[N]) {
  json j = json::array();
  for (int8_t x : a) j.push_back(static_cast<int>(x));
  return j;
}

json to_json(const humanoid::robot_state_t& m) {
  return {{"tick", m.tick},           {"utime", m.utime},         {"p_WB", arr(m.p_WB)},
          {"quat_WB", arr(m.quat_WB)}, {"v_WB", arr(m.v_WB)},       {"omega_WB", arr(m.omega_WB)},
          {"p_WCom", arr(m.p_WCom)},   {"v_WCom", arr(m.v_WCom)},   {"joint_name", m.joint_name},
          {"q", arr(m.q)},             {"qd", arr(m.qd)},           {"tau", arr(m.tau)},
          {"foot_name", m.foot_name},  {"foot_contact", flags(m.foot_contact)},
          {"foot_force_z", arr(m.foot_force_z)}, {"l_WCom", arr(m.l_WCom)}, {"ldot_WCom", arr(m.ldot_WCom)},
          {"status", m.status}};
}

json to_json(const humanoid::sim_truth_t& m) {
  return {{"tick", m.tick},
          {"utime", m.utime},
          {"sim_time", num(m.sim_time)},
          {"p_WB", arr(m.p_WB)},
          {"quat_WB", arr(m.quat_WB)},
          {"p_WCom", arr(m.p_WCom)},
          {"v_WCom", arr(m.v_WCom)},
          {"l_WCom", arr(m.l_WCom)},
          {"foot_name", m.foot_name},
          {"p_WF", arr2(m.p_WF)},
          {"quat_WF", arr2(m.quat_WF)},
          {"foot_contact", flags(m.foot_contact)},
          {"push_id", m.push_id},
          {"push_active", m.push_active != 0},
          {"push_force_W", arr(m.push_force_W)},
          {"push_impulse_W", arr(m.push_impulse_W)},
          {"push_point_W", arr(m.push_point_W)},
          {"fallen", m.fallen != 0}};
}

json to_json(const humanoid::push_t& m) {
  return {{"tick", m.tick},           {"utime", m.utime},       {"id", m.id},
          {"link", m.link},           {"point_L", arr(m.point_L)}, {"force_W", arr(m.force_W)},
          {"start_time", num(m.start_time)}, {"duration", num(m.duration)}, {"profile", static_cast<int>(m.profile)}};
}

json to_json(const humanoid::balance_status_t& m) {
  return {{"tick", m.tick},
          {"utime", m.utime},
          {"support", static_cast<int>(m.support)},
          {"p_WV", arr(m.p_WV)},
          {"yaw_WV", num(m.yaw_WV)},
          {"tau_ankle_V", arr(m.tau_ankle_V)},
          {"tau_hip_V", arr(m.tau_hip_V)},
          {"tau_V", arr(m.tau_V)},
          {"tau_min_V", arr(m.tau_min_V)},
          {"tau_max_V", arr(m.tau_max_V)},
          {"cop_V", arr(m.cop_V)},
          {"cop_measured_V", arr(m.cop_measured_V)},
          {"f_vz", num(m.f_vz)},
          {"qp_status", m.qp_status},
          {"qp_fallback", m.qp_fallback != 0}};
}

json to_json(const humanoid::cam_reference_t& m) {
  return {{"tick", m.tick},           {"utime", m.utime},         {"l_ref_W", arr(m.l_ref_W)},
          {"l_ref_V", arr(m.l_ref_V)}, {"yaw_WV", num(m.yaw_WV)}, {"phase", ints(m.phase)},
          {"status", m.status}};
}

json to_json(const humanoid::wholebody_command_t& m) {
  return {{"tick", m.tick},     {"utime", m.utime},         {"support", static_cast<int>(m.support)},
          {"p_WCom", arr(m.p_WCom)}, {"l_cmd_W", arr(m.l_cmd_W)}, {"l_ref_W", arr(m.l_ref_W)},
          {"posture_error", num(m.posture_error)}, {"stepping", m.stepping != 0}, {"xi_W", arr(m.xi_W)},
          {"xi_excess", num(m.xi_excess)}, {"step_foot", m.step_foot}, {"step_target_W", arr(m.step_target_W)},
          {"step_time_left", num(m.step_time_left)}, {"steps_taken", m.steps_taken}, {"follow_steps", m.follow_steps}};
}

json to_json(const humanoid::balance_plan_t& m) {
  return {{"tick", m.tick},     {"utime", m.utime},         {"support", static_cast<int>(m.support)},
          {"stage", static_cast<int>(m.stage)}, {"settled", m.settled != 0}, {"p_WCom", arr(m.p_WCom)},
          {"f_ext_W", arr(m.f_ext_W)}, {"stepping", m.stepping != 0}, {"xi_W", arr(m.xi_W)},
          {"xi_excess", num(m.xi_excess)}, {"step_foot", m.step_foot}, {"step_target_W", arr(m.step_target_W)},
          {"step_time_left", num(m.step_time_left)}, {"steps_taken", m.steps_taken}, {"follow_steps", m.follow_steps}};
}

json to_json(const humanoid::health_t& m) {
  return {{"tick", m.tick},
          {"utime", m.utime},
          {"node", m.node},
          {"pid", m.pid},
          {"state", static_cast<int>(m.state)},
          {"lifecycle", static_cast<int>(m.lifecycle)},
          {"rate_hz", num(m.rate_hz)},
          {"cycle_median_us", num(m.cycle_median_us)},
          {"deadline_misses", m.deadline_misses},
          {"decode_errors", m.decode_errors},
          {"log_suppressed", m.log_suppressed},
          {"unauthenticated", m.unauthenticated},
          {"faults", m.faults}};
}

/// An example message with one item in every variable-length array (for the schema).
template <class Msg>
Msg example() {
  return Msg{};
}
template <>
humanoid::robot_state_t example() {
  humanoid::robot_state_t m{};
  m.num_joints = 1;
  m.joint_name = {"j"};
  m.q = m.qd = m.tau = {0.0};
  m.num_feet = 1;
  m.foot_name = {"f"};
  m.foot_contact = {1};
  m.foot_force_z = {0.0};
  m.foot_wrench_W = {std::vector<double>(6, 0.0)};
  return m;
}
template <>
humanoid::sim_truth_t example() {
  humanoid::sim_truth_t m{};
  m.num_feet = 1;
  m.foot_name = {"f"};
  m.p_WF = {std::vector<double>(3, 0.0)};
  m.quat_WF = {std::vector<double>(4, 0.0)};
  m.contact_wrench_W = {std::vector<double>(6, 0.0)};
  m.foot_contact = {1};
  m.foot_tilt = {0.0};
  return m;
}
template <>
humanoid::health_t example() {
  humanoid::health_t m{};
  m.num_faults = 1;
  m.faults = {"f"};
  return m;
}

struct Codec {
  ChannelInfo info;
  std::function<Decoded(const void*, std::size_t)> decode;
};

template <class Msg>
Codec codec(const Channel<Msg>& ch, bool robot_clock = true) {
  const char* channel = ch.name;
  Codec c;
  c.info.name = channel;
  c.info.schema_name = std::string("humanoid.") + Msg::getTypeName();
  c.info.schema = schema_of(to_json(example<Msg>()));
  c.info.robot_clock = robot_clock;
  c.decode = [channel](const void* data, std::size_t size) {
    Msg m{};
    int used = -1;
    try {
      used = m.decode(data, 0, static_cast<int>(size));
    } catch (const std::exception& e) {
      throw DecodeError(fmt::format("{}: a message of {} bytes is not a valid {} ({})", channel, size, Msg::getTypeName(), e.what()));
    }
    if (used < 0) {
      throw DecodeError(fmt::format("{}: a message of {} bytes is not a valid {}", channel, size, Msg::getTypeName()));
    }
    return Decoded{to_json(m), m.tick, m.utime};
  };
  return c;
}

const std::vector<Codec>& codecs() {
  static const std::vector<Codec> all{
      codec(msg::channels::kRobotState),    codec(msg::channels::kSimTruth),     codec(msg::channels::kPush),
      codec(msg::channels::kBalancePlan),   codec(msg::channels::kBalanceStatus), codec(msg::channels::kCamReference),
      codec(msg::channels::kWholebodyCommand), codec(msg::channels::kHealth, false)};
  return all;
}

}  // namespace

const std::vector<ChannelInfo>& channels() {
  static const std::vector<ChannelInfo> all = [] {
    std::vector<ChannelInfo> v;
    for (const auto& c : codecs()) v.push_back(c.info);
    return v;
  }();
  return all;
}

int channel_index(const std::string& name) {
  const auto& all = channels();
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (all[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

Decoded decode(const std::string& channel, const void* data, std::size_t size) {
  const int i = channel_index(channel);
  if (i < 0) throw DecodeError(fmt::format("{}: not a channel the viewer shows", channel));
  return codecs()[static_cast<std::size_t>(i)].decode(data, size);
}

nlohmann::json schema_of(const nlohmann::json& example) {
  using nlohmann::json;
  switch (example.type()) {
    case json::value_t::object: {
      json props = json::object();
      json required = json::array();
      for (const auto& [k, v] : example.items()) {
        props[k] = schema_of(v);
        required.push_back(k);
      }
      return {{"type", "object"}, {"properties", props}, {"required", required}};
    }
    case json::value_t::array:
      return example.empty() ? json{{"type", "array"}} : json{{"type", "array"}, {"items", schema_of(example.front())}};
    case json::value_t::boolean:
      return {{"type", "boolean"}};
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
      return {{"type", "integer"}};
    case json::value_t::number_float:
      return {{"type", {"number", "null"}}};
    case json::value_t::string:
      return {{"type", "string"}};
    default:
      return {{"type", "null"}};
  }
}

}  // namespace hpr::viewer
