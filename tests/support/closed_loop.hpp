#pragma once
// The in-process closed loop (hpr/closed_loop) for a robot of this tree's config folder, by name.
#include <string>
#include <vector>

#include "hpr/closed_loop/closed_loop.hpp"
#include "process_group.hpp"

namespace hpr::test {

using closed_loop::ClosedLoopOptions;

struct ClosedLoop : closed_loop::ClosedLoop {
  explicit ClosedLoop(const std::string& robot, const std::vector<std::string>& overrides = {}, ClosedLoopOptions options = {})
      : closed_loop::ClosedLoop(source_dir() + "/config/" + robot + ".yaml", overrides, options) {}
};

}  // namespace hpr::test
