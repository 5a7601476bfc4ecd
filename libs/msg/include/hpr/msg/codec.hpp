#pragma once
/// \file
/// Each channel's message and the value a component takes or gives, converted one way for every
/// reader and writer: `Codec<Msg>` decodes a message into its value (refusing it with the reason)
/// and encodes a value into its message, given what the conversions need to know of the robot
/// (`Naming`). The generic node (hpr/graph/component_node.hpp) and the composed controllers
/// (hpr/graph/controllers.hpp) pass every channel through it, so a value crosses a process boundary
/// and the in-process one alike.

#include <string>
#include <vector>

#include "hpr/model/robot.hpp"
#include "hpr/msg/balance.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/commands.hpp"
#include "hpr/msg/plan.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/msg/sim_truth.hpp"
#include "hpr/msg/state.hpp"

namespace hpr::msg {

/// What the conversions need to know of the robot: the joints' and feet's names, and the free
/// joints' (RobotSpec::free_joints order).
struct Naming {
  RobotNames names;
  std::vector<std::string> free_names;

  [[nodiscard]] static Naming of(const model::RobotSpec& robot) {
    Naming n;
    n.names.joints = robot.model.joint_name;
    for (int j : robot.free_joints) n.free_names.push_back(robot.model.joint_name[static_cast<size_t>(j)]);
    return n;
  }
};

/// The conversion of message `Msg`: `Value`, `decode` (empty when `m` is valid, filled into `v`;
/// else the reason, `v` then unspecified) and `encode`.
template <class Msg>
struct Codec;

template <>
struct Codec<humanoid::robot_sensors_t> {
  using Value = SensorSample;
  static std::string decode(const humanoid::robot_sensors_t& m, const Naming& n, Value& v) { return from_message(m, n.names, v); }
  static void encode(const Value& v, const Naming& n, humanoid::robot_sensors_t& m) { to_message(v, n.names, m); }
};

template <>
struct Codec<humanoid::robot_state_t> {
  using Value = EstimatedState;
  static std::string decode(const humanoid::robot_state_t& m, const Naming& n, Value& v) { return from_message(m, n.names, v); }
  static void encode(const Value& v, const Naming& n, humanoid::robot_state_t& m) { to_message(v, n.names, m); }
};

template <>
struct Codec<humanoid::balance_plan_t> {
  using Value = balance::BalancePlan;
  static std::string decode(const humanoid::balance_plan_t& m, const Naming& n, Value& v) { return from_message(m, n.free_names, v); }
  static void encode(const Value& v, const Naming& n, humanoid::balance_plan_t& m) { to_message(v, n.free_names, n.names, m); }
};

template <>
struct Codec<humanoid::cam_reference_t> {
  using Value = balance::CamReference;
  static std::string decode(const humanoid::cam_reference_t& m, const Naming&, Value& v) { return from_message(m, v); }
  static void encode(const Value& v, const Naming&, humanoid::cam_reference_t& m) { to_message(v, m); }
};

template <>
struct Codec<humanoid::wholebody_command_t> {
  using Value = balance::WholebodyCommand;
  static std::string decode(const humanoid::wholebody_command_t& m, const Naming& n, Value& v) { return from_message(m, n.free_names, v); }
  static void encode(const Value& v, const Naming& n, humanoid::wholebody_command_t& m) { to_message(v, n.free_names, n.names, m); }
};

template <>
struct Codec<humanoid::balance_status_t> {
  using Value = balance::BalanceStatus;
  static std::string decode(const humanoid::balance_status_t& m, const Naming&, Value& v) { return from_message(m, v); }
  static void encode(const Value& v, const Naming& n, humanoid::balance_status_t& m) { to_message(v, n.names, m); }
};

template <>
struct Codec<humanoid::joint_command_t> {
  using Value = JointCommand;
  static std::string decode(const humanoid::joint_command_t& m, const Naming& n, Value& v) { return from_message(m, n.names, v); }
  static void encode(const Value& v, const Naming& n, humanoid::joint_command_t& m) { to_message(v, n.names, m); }
};

template <>
struct Codec<humanoid::sim_truth_t> {
  using Value = SimTruth;
  static std::string decode(const humanoid::sim_truth_t& m, const Naming&, Value& v) { return from_message(m, v); }
  static void encode(const Value& v, const Naming& n, humanoid::sim_truth_t& m) { to_message(v, n.names.feet, m); }
};

/// OPERATOR is taken as it is, once checked (its commands are events, not a state to convert).
template <>
struct Codec<humanoid::operator_t> {
  using Value = humanoid::operator_t;
  static std::string decode(const humanoid::operator_t& m, const Naming&, Value& v) {
    std::string why = check_operator(m);
    if (why.empty()) v = m;
    return why;
  }
  static void encode(const Value& v, const Naming&, humanoid::operator_t& m) { m = v; }
};

/// The value channel `Ch` carries.
template <const auto& Ch>
using ValueOf = typename Codec<typename std::remove_cvref_t<decltype(Ch)>::Message>::Value;

}  // namespace hpr::msg
