#pragma once
// The in-process closed loop (hpr/graph) for a robot of this tree's config folder, by name.
#include <string>
#include <vector>

#include "hpr/graph/closed_loop.hpp"
#include "process_group.hpp"

namespace hpr::test {

using graph::ClosedLoopOptions;

struct ClosedLoop : graph::ClosedLoop {
  explicit ClosedLoop(const std::string& robot, const std::vector<std::string>& overrides = {}, ClosedLoopOptions loop_options = {})
      : graph::ClosedLoop(source_dir() + "/config/" + robot + ".yaml", overrides, loop_options) {}
};

}  // namespace hpr::test
