#pragma once
/// \file
/// Minimal leveled logging to stderr: "[time] [name] level: message". One line per call, written
/// with a single write so that lines of concurrent processes do not interleave.
///
/// Repeats are rate limited per call site (its format string): at most `kBurst` lines of one call
/// site per second; the rest are counted, and the first line of that call site after the second
/// (or flush_repeats(), which the node runtime calls with every HEALTH) says the last of them with
/// "(and N more like this in the last second)". suppressed() counts them for HEALTH. A process
/// that a fault makes warn on every tick thus writes a few lines a second, not a thousand.

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
/// Writes a line of call site `site` (its format string), rate limited (see the file comment).
void write_limited(Level level, const void* site, std::string_view message);
[[nodiscard]] bool enabled(Level level);
/// Lines of one call site written per second before the rest are counted instead.
inline constexpr int kBurst = 5;
/// Writes the count of the lines held back in seconds that have ended (`all`: also in the
/// current one, as a process does before it exits).
void flush_repeats(bool all = false);
/// Lines held back since the process started.
[[nodiscard]] long long suppressed();

template <class... Args>
void debug(fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(Level::kDebug)) write(Level::kDebug, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void info(fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(Level::kInfo)) write_limited(Level::kInfo, static_cast<fmt::string_view>(f).data(), fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void warn(fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(Level::kWarn)) write_limited(Level::kWarn, static_cast<fmt::string_view>(f).data(), fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void error(fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(Level::kError)) write_limited(Level::kError, static_cast<fmt::string_view>(f).data(), fmt::format(f, std::forward<Args>(args)...));
}

}  // namespace hpr::log
