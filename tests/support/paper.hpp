#pragma once
// The paper's configuration (config/overlays/paper.yaml) as overrides, for tests that reproduce
// the paper's experiments or compare with its two strategies.
#include <string>
#include <vector>

#include "hpr/experiments/trial.hpp"
#include "process_group.hpp"

namespace hpr::test {

/// config/overlays/paper.yaml's keys, then `overrides` (which win).
inline std::vector<std::string> paper_and(const std::vector<std::string>& overrides = {}) {
  std::vector<std::string> o = experiments::overlay_overrides(source_dir() + "/config/overlays/paper.yaml");
  o.insert(o.end(), overrides.begin(), overrides.end());
  return o;
}

}  // namespace hpr::test
