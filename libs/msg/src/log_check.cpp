#include "hpr/msg/log_check.hpp"

#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/hal_status_t.hpp>
#include <humanoid/health_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/params_t.hpp>
#include <humanoid/push_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/sim_truth_t.hpp>
#include <humanoid/supervisor_command_t.hpp>
#include <humanoid/supervisor_status_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include "hpr/common/auth.hpp"

namespace hpr::msg {
namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0 &&
         (s.size() == suffix.size() || s[s.size() - suffix.size() - 1] == '/' || s[s.size() - suffix.size() - 1] == '_' ||
          s[s.size() - suffix.size() - 1] == '.');
}

/// Calls f.template operator()<Msg>() for the type of `channel`; false when it has none.
template <class F>
bool with_type(const std::string& channel, F&& f) {
  // Longest names first: no channel name is the end of another's.
  if (ends_with(channel, "SUPERVISOR_COMMAND")) return f.template operator()<humanoid::supervisor_command_t>(), true;
  if (ends_with(channel, "SUPERVISOR_STATUS")) return f.template operator()<humanoid::supervisor_status_t>(), true;
  if (ends_with(channel, "WHOLEBODY_COMMAND")) return f.template operator()<humanoid::wholebody_command_t>(), true;
  if (ends_with(channel, "BALANCE_STATUS")) return f.template operator()<humanoid::balance_status_t>(), true;
  if (ends_with(channel, "CAM_REFERENCE")) return f.template operator()<humanoid::cam_reference_t>(), true;
  if (ends_with(channel, "JOINT_COMMAND")) return f.template operator()<humanoid::joint_command_t>(), true;
  if (ends_with(channel, "ROBOT_SENSORS")) return f.template operator()<humanoid::robot_sensors_t>(), true;
  if (ends_with(channel, "ROBOT_STATE")) return f.template operator()<humanoid::robot_state_t>(), true;
  if (ends_with(channel, "HAL_STATUS")) return f.template operator()<humanoid::hal_status_t>(), true;
  if (ends_with(channel, "SIM_TRUTH")) return f.template operator()<humanoid::sim_truth_t>(), true;
  if (ends_with(channel, "OPERATOR")) return f.template operator()<humanoid::operator_t>(), true;
  if (ends_with(channel, "HEALTH")) return f.template operator()<humanoid::health_t>(), true;
  if (ends_with(channel, "PARAMS")) return f.template operator()<humanoid::params_t>(), true;
  if (ends_with(channel, "PUSH")) return f.template operator()<humanoid::push_t>(), true;
  return false;
}

}  // namespace

std::string type_of_channel(const std::string& channel) {
  std::string out;
  with_type(channel, [&]<class Msg>() { out = std::string("humanoid.") + Msg::getTypeName(); });
  return out;
}

bool carries_code(const std::string& channel) {
  bool signed_type = false;
  with_type(channel, [&]<class Msg>() { signed_type = auth::Signed<Msg>; });
  return signed_type;
}

std::string check_message(const std::string& channel, const void* data, int size) {
  std::string why;
  with_type(channel, [&]<class Msg>() {
    Msg m;
    bool ok = false;
    try {
      ok = m.decode(data, 0, size) == size;
    } catch (const std::exception&) {
      ok = false;
    }
    if (!ok) why = std::string("does not decode as humanoid.") + Msg::getTypeName();
  });
  return why;
}

}  // namespace hpr::msg
