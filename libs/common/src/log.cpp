#include "hpr/common/log.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <ctime>

namespace hpr::log {
namespace {
std::string g_name = "hpr";
Level g_level = Level::kInfo;

const char* level_name(Level l) {
  switch (l) {
    case Level::kDebug: return "debug";
    case Level::kInfo: return "info";
    case Level::kWarn: return "warn";
    case Level::kError: return "error";
  }
  return "?";
}
}  // namespace

void init(std::string name, Level level) {
  g_name = std::move(name);
  g_level = level;
}

void init_from_env(std::string name) {
  Level level = Level::kInfo;
  if (const char* env = std::getenv("HPR_LOG_LEVEL")) {
    const std::string_view v(env);
    if (v == "debug") level = Level::kDebug;
    else if (v == "warn") level = Level::kWarn;
    else if (v == "error") level = Level::kError;
  }
  init(std::move(name), level);
}

bool enabled(Level level) { return static_cast<int>(level) >= static_cast<int>(g_level); }

void write(Level level, std::string_view message) {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm tm{};
  localtime_r(&t, &tm);
  const std::string line = fmt::format("[{:02}:{:02}:{:02}.{:03}] [{}] {}: {}\n", tm.tm_hour, tm.tm_min,
                                       tm.tm_sec, ms, g_name, level_name(level), message);
  const ssize_t ignored = ::write(STDERR_FILENO, line.data(), line.size());
  (void)ignored;
}

}  // namespace hpr::log
