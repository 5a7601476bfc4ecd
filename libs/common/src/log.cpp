#include "hpr/common/log.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <mutex>
#include <unordered_map>

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
/// One call site's current second.
struct Site {
  double window_start = -1e18;  ///< [s] monotonic
  int written = 0;
  long long held = 0;
  Level level = Level::kInfo;
  std::string last;  ///< the last line held back
};
std::mutex g_mutex;
std::unordered_map<const void*, Site> g_sites;
long long g_suppressed = 0;

double monotonic_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Says how many lines of `site` were held back in its second that has ended; g_mutex held.
void close_window(Site& site) {
  if (site.held == 0) return;
  if (site.held == 1) {
    write(site.level, site.last);
  } else {
    write(site.level, fmt::format("{} (and {} more like this in the last second)", site.last, site.held - 1));
  }
  site.held = 0;
  site.last.clear();
}
}  // namespace

void write_limited(Level level, const void* site_key, std::string_view message) {
  const double now = monotonic_now();
  const std::lock_guard<std::mutex> lock(g_mutex);
  Site& site = g_sites[site_key];
  if (now - site.window_start >= 1.0) {
    close_window(site);
    site.window_start = now;
    site.written = 0;
  }
  if (site.written < kBurst) {
    ++site.written;
    write(level, message);
    return;
  }
  ++site.held;
  ++g_suppressed;
  site.level = level;
  site.last.assign(message);
}

void flush_repeats(bool all) {
  const double now = monotonic_now();
  const std::lock_guard<std::mutex> lock(g_mutex);
  for (auto& [key, site] : g_sites) {
    if (site.held > 0 && (all || now - site.window_start >= 1.0)) close_window(site);
  }
}

long long suppressed() {
  const std::lock_guard<std::mutex> lock(g_mutex);
  return g_suppressed;
}

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
