#pragma once
/// \file
/// The stack's data flow, declared once (README.md, "The processes"): every process, the channels it
/// reads (which tick, relative to the tick it steps on, whether it steps on it, whether it can go
/// on without it) and the channels it writes. The nodes take their tick synchronisation from it,
/// replay_check the outputs it compares, and the supervisor checks a group against it (a process
/// whose required input no process of the group writes).

#include <string>
#include <vector>

namespace hpr::msg {

/// How a process reads a channel.
struct Read {
  std::string channel;
  int tick_offset = 0;    ///< the tick read, relative to the tick of the step (−1: the previous tick's)
  bool trigger = false;   ///< the process steps on each tick of this channel
  bool optional = false;  ///< the step goes on without it (after its timeout, with a fallback)
  std::string use;        ///< what the process does with it
};

struct ProcessPorts {
  std::string name;  ///< the process (and its executable)
  std::vector<Read> reads;
  std::vector<std::string> writes;  ///< data channels (HEALTH and PARAMS, which every node has, left out)
};

/// Every process of the stack, in the order of one tick's data flow.
const std::vector<ProcessPorts>& data_flow();
/// The process named `name`, or nullptr when it is not one of the stack's.
const ProcessPorts* find_process(const std::string& name);
/// How `process` reads `channel`; throws std::invalid_argument when it does not.
const Read& read_of(const std::string& process, const std::string& channel);

/// For processes run together (names of data_flow(); others are ignored): each required input
/// that none of them writes, as "wbc reads ROBOT_STATE (the state it controls), which none of
/// them writes".
std::vector<std::string> unmet_inputs(const std::vector<std::string>& processes);

}  // namespace hpr::msg
