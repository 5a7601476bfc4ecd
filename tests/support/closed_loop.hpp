#pragma once
// The in-process closed loop (hpr/pipeline) for a robot of this tree's config folder, by name.
#include <string>
#include <vector>

#include "hpr/pipeline/closed_loop.hpp"
#include "process_group.hpp"

namespace hpr::test {

using pipeline::ClosedLoopOptions;

struct ClosedLoop : pipeline::ClosedLoop {
  explicit ClosedLoop(const std::string& robot, const std::vector<std::string>& overrides = {}, ClosedLoopOptions loop_options = {})
      : pipeline::ClosedLoop(source_dir() + "/config/" + robot + ".yaml", overrides, loop_options) {}
};

}  // namespace hpr::test
