#pragma once
/// \file
/// The stack's data flow (README.md, "The processes"), gathered from the ports each process
/// declares beside its component (hpr/common/ports.hpp): every process with the channels it reads
/// and writes, in the order of one tick's data flow. The composed `controllers` process's ports are
/// computed from its five components': it reads what they read and none of them writes, and writes
/// what they write. The supervisor checks a group against it (a process whose required input no
/// process of the group writes), and replay_check compares the outputs it lists.

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hpr/common/ports.hpp"

namespace hpr::graph {

/// Every process of the stack, in the order of one tick's data flow.
std::span<const Ports> data_flow();
/// The process named `name`, or nullptr when it is not one of the stack's.
const Ports* find_process(std::string_view name);
/// How `process` reads `channel`; throws std::invalid_argument when it does not.
const Read& read_of(std::string_view process, std::string_view channel);
/// The ports of the processes `parts` run in one process: the channels they read that none of them
/// writes (a trigger if any part steps on it, optional if every part can do without it; its use
/// says which part reads it for what), and every channel they write.
Ports composed(std::string_view name, std::span<const Ports> parts);
/// The composed controllers process's ports: composed() of estimator, planner, reference_gen, motion_opt, wbc.
const Ports& controllers_ports();

/// For processes run together (names of data_flow(); others are ignored): each required input
/// that none of them writes, as "wbc reads ROBOT_STATE (the state it controls), which none of
/// them writes".
std::vector<std::string> unmet_inputs(const std::vector<std::string>& processes);

}  // namespace hpr::graph
