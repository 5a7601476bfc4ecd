#pragma once
/// \file
/// An empty folder of a test's own under the temporary directory, removed with everything in it
/// when the object goes (a test's, or at exit for a static one).
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace hpr::test {

class ScratchDir {
 public:
  /// `name`: what the folder is for (it is named hpr-<name>-<pid>).
  explicit ScratchDir(const std::string& name)
      : path_(std::filesystem::temp_directory_path() / ("hpr-" + name + "-" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace hpr::test
