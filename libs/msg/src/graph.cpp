#include "hpr/msg/graph.hpp"

#include <algorithm>
#include <stdexcept>

namespace hpr::msg {

const std::vector<ProcessPorts>& data_flow() {
  static const std::vector<ProcessPorts> kFlow = {
      {"sim_bullet",
       {{"JOINT_COMMAND", -1, false, true, "drive commands (in lockstep the step waits for the answer to its last sensors)"},
        {"PUSH", 0, false, true, "pushes to apply"}},
       {"ROBOT_SENSORS", "SIM_TRUTH"}},
      {"hal",
       {{"JOINT_COMMAND", -1, false, true, "drive commands (stale ones time out to damping)"},
        {"OPERATOR", 0, false, true, "enable, damp, stop"}},
       {"ROBOT_SENSORS", "HAL_STATUS"}},
      {"drive_emulator", {{"PUSH", 0, false, true, "pushes to apply"}}, {"SIM_TRUTH"}},
      {"estimator", {{"ROBOT_SENSORS", 0, true, false, "the sample it filters"}}, {"ROBOT_STATE"}},
      {"reference_gen",
       {{"ROBOT_STATE", 0, true, false, "tick and time"},
        {"BALANCE_STATUS", -1, false, true, "the ankle torque and its limits (the paper's one-period lag)"},
        {"WHOLEBODY_COMMAND", -1, false, true, "the posture error that ends phase 3"}},
       {"CAM_REFERENCE"}},
      {"motion_opt",
       {{"ROBOT_STATE", 0, true, false, "the state it optimises from"},
        {"CAM_REFERENCE", 0, false, true, "l_c^ref (without it: the posture task only)"},
        {"OPERATOR", 0, false, true, "support requests"}},
       {"WHOLEBODY_COMMAND"}},
      {"wbc",
       {{"ROBOT_STATE", 0, true, false, "the state it controls"},
        {"WHOLEBODY_COMMAND", 0, false, true, "the task-space command (without it: its own posture reference)"},
        {"OPERATOR", 0, false, true, "enable, damp, stop, support requests"}},
       {"JOINT_COMMAND", "BALANCE_STATUS"}},
      {"controllers",
       {{"ROBOT_SENSORS", 0, true, false, "the sample the four composed controllers step on"},
        {"OPERATOR", 0, false, true, "enable, damp, stop, support requests"}},
       {"ROBOT_STATE", "CAM_REFERENCE", "WHOLEBODY_COMMAND", "JOINT_COMMAND", "BALANCE_STATUS"}},
  };
  return kFlow;
}

const ProcessPorts* find_process(const std::string& name) {
  for (const auto& p : data_flow()) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

const Read& read_of(const std::string& process, const std::string& channel) {
  const ProcessPorts* p = find_process(process);
  if (p == nullptr) throw std::invalid_argument("'" + process + "' is not a process of the stack");
  for (const auto& r : p->reads) {
    if (r.channel == channel) return r;
  }
  throw std::invalid_argument(process + " does not read " + channel);
}

std::vector<std::string> unmet_inputs(const std::vector<std::string>& processes) {
  std::vector<std::string> written;
  for (const auto& n : processes) {
    if (const ProcessPorts* p = find_process(n)) written.insert(written.end(), p->writes.begin(), p->writes.end());
  }
  std::vector<std::string> unmet;
  for (const auto& n : processes) {
    const ProcessPorts* p = find_process(n);
    if (p == nullptr) continue;
    for (const auto& r : p->reads) {
      if (r.optional || std::find(written.begin(), written.end(), r.channel) != written.end()) continue;
      unmet.push_back(n + " reads " + r.channel + " (" + r.use + "), which none of them writes");
    }
  }
  return unmet;
}

}  // namespace hpr::msg
