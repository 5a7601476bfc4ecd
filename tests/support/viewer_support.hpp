#pragma once
/// \file Integration-test support for the viewer: writing LCM logs, starting the viewer and finding
/// the port it took.

#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "process_group.hpp"

namespace hpr::test {

/// Writes messages to an LCM log in order.
class LogWriter {
 public:
  explicit LogWriter(const std::string& path) : log_(path, "w") {
    if (!log_.good()) throw std::runtime_error("cannot write " + path);
  }
  template <class Msg>
  void write(const std::string& channel, const Msg& m, std::int64_t timestamp_us) {
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(buf.data(), 0, static_cast<int>(buf.size()));
    write_raw(channel, buf, timestamp_us);
  }
  void write_raw(const std::string& channel, std::vector<std::uint8_t> bytes, std::int64_t timestamp_us) {
    lcm::LogEvent ev{};
    ev.timestamp = timestamp_us;
    ev.channel = channel;
    ev.datalen = static_cast<int32_t>(bytes.size());
    ev.data = bytes.data();
    log_.writeEvent(&ev);
  }

 private:
  lcm::LogFile log_;
};

inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Starts the viewer with `args` (its output in `log_file`) and returns the port it announces, or
/// -1 when it does not within the timeout.
inline int start_viewer(ProcessGroup& group, const std::vector<std::string>& args, const std::string& log_file,
                        std::chrono::seconds timeout = std::chrono::seconds(30)) {
  const pid_t pid = group.start("viewer", args, {}, log_file);
  const std::regex re("viewer: .* at http://127\\.0\\.0\\.1:([0-9]+)/");
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    std::smatch m;
    const std::string text = read_text(log_file);
    if (std::regex_search(text, m, re)) return std::stoi(m[1]);
    if (!group.running(pid)) return -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return -1;
}

}  // namespace hpr::test
