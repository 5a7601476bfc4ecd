#include "process_group.hpp"

#include <unistd.h>

#include <filesystem>

namespace hpr::test {

std::string bin_dir() { return HPR_TEST_BIN_DIR; }
std::string source_dir() { return HPR_TEST_SOURCE_DIR; }

std::string temp_dir(const std::string& tag) {
  const auto dir = std::filesystem::path(HPR_TEST_WORK_DIR) / (tag + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

}  // namespace hpr::test
