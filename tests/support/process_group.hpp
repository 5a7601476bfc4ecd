#pragma once
/// \file
/// Integration-test support: the stack's process launcher with each test on its own LCM URL and
/// the executables of this build tree; everything started is killed when the test ends, even when
/// it fails.

#include <string>

#include "hpr/launch/process_group.hpp"

namespace hpr::test {

using launch::ProcessResult;
using launch::unique_lcm_url;

/// Directory of the built executables and of the source tree (set by CMake).
std::string bin_dir();
std::string source_dir();
/// A fresh, empty directory for this test's files.
std::string temp_dir(const std::string& tag);

class ProcessGroup : public launch::ProcessGroup {
 public:
  explicit ProcessGroup(std::string lcm_url = unique_lcm_url()) : launch::ProcessGroup(std::move(lcm_url), test::bin_dir()) {}
};

}  // namespace hpr::test
