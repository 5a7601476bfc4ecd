#pragma once
/// \file
/// Minimal leveled logging to stderr: "[time] [name] level: message". One line per call, written
/// with a single write so that lines of concurrent processes do not interleave.

#include <fmt/format.h>

#include <string>
#include <string_view>

namespace hpr::log {

enum class Level { kDebug = 0, kInfo = 1, kWarn = 2, kError = 3 };

/// Sets the name printed on every line (the process name) and the minimum level.
void init(std::string name, Level level = Level::kInfo);
/// Level from the environment variable HPR_LOG_LEVEL (debug, info, warn, error), if set.
void init_from_env(std::string name);
void write(Level level, std::string_view message);
[[nodiscard]] bool enabled(Level level);

template <class... Args>
void debug(fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(Level::kDebug)) write(Level::kDebug, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void info(fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(Level::kInfo)) write(Level::kInfo, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void warn(fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(Level::kWarn)) write(Level::kWarn, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void error(fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(Level::kError)) write(Level::kError, fmt::format(f, std::forward<Args>(args)...));
}

}  // namespace hpr::log
