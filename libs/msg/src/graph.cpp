#include "hpr/msg/graph.hpp"

#include "hpr/msg/channels.hpp"

#include <algorithm>
#include <stdexcept>

namespace hpr::msg {

const std::vector<ProcessPorts>& data_flow() {
  static const std::vector<ProcessPorts> kFlow = {
      {"sim_bullet",
       {{channels::kJointCommand.name, -1, false, true, "drive commands (in lockstep the step waits for the answer to its last sensors)"},
        {channels::kPush.name, 0, false, true, "pushes to apply"}},
       {channels::kRobotSensors.name, channels::kSimTruth.name}},
      {"hal",
       {{channels::kJointCommand.name, -1, false, true, "drive commands (stale ones time out to damping)"},
        {channels::kOperator.name, 0, false, true, "enable, damp, stop"}},
       {channels::kRobotSensors.name, channels::kHalStatus.name}},
      {"drive_emulator", {{channels::kPush.name, 0, false, true, "pushes to apply"}}, {channels::kSimTruth.name}},
      {"estimator", {{channels::kRobotSensors.name, 0, true, false, "the sample it filters"}}, {channels::kRobotState.name}},
      {"truth_state",
       {{channels::kRobotSensors.name, 0, true, false, "the joints and the tick"},
        {channels::kSimTruth.name, 0, false, false, "the simulator's base, CoM and contacts of the same tick"}},
       {channels::kRobotState.name}},
      {"reference_gen",
       {{channels::kRobotState.name, 0, true, false, "tick and time"},
        {channels::kBalanceStatus.name, -1, false, true, "the ankle torque and its limits (the paper's one-period lag)"},
        {channels::kWholebodyCommand.name, -1, false, true, "the posture error that ends phase 3"}},
       {channels::kCamReference.name}},
      {"motion_opt",
       {{channels::kRobotState.name, 0, true, false, "the state it optimises from"},
        {channels::kCamReference.name, 0, false, true, "l_c^ref (without it: the posture task only)"},
        {channels::kOperator.name, 0, false, true, "support requests"}},
       {channels::kWholebodyCommand.name}},
      {"wbc",
       {{channels::kRobotState.name, 0, true, false, "the state it controls"},
        {channels::kWholebodyCommand.name, 0, false, true, "the task-space command (without it: its own posture reference)"},
        {channels::kOperator.name, 0, false, true, "enable, damp, stop, support requests"}},
       {channels::kJointCommand.name, channels::kBalanceStatus.name}},
      {"controllers",
       {{channels::kRobotSensors.name, 0, true, false, "the sample the four composed controllers step on"},
        {channels::kOperator.name, 0, false, true, "enable, damp, stop, support requests"}},
       {channels::kRobotState.name, channels::kCamReference.name, channels::kWholebodyCommand.name, channels::kJointCommand.name, channels::kBalanceStatus.name}},
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
