// lcm_recorder: records LCM traffic into an LCM log file (the format of lcm-logger, read by
// lcm-logplayer, lcm-spy, tools/replay and lcm_export) without losing messages under load.
//
// lcm-logger keeps LCM's default subscription queue of 30 messages: with the whole stack at
// 1 kHz (about 8 messages per tick, more in lockstep) a logger held up for 4 ms loses messages.
// This recorder queues up to --queue messages, asks the kernel for a socket buffer of seconds of
// traffic, and on exit says which ticks of the data-flow channels are missing, so that a log is
// known complete or known holed.
//
// Exit status: 0 recorded (complete), 1 error, 2 bad use, 3 recorded with missing ticks, 4 (--check)
// undecodable messages in the log.
#include <fmt/format.h>

#include <csignal>
#include <filesystem>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <string>

#include "hpr/common/args.hpp"
#include "hpr/common/time.hpp"
#include "hpr/msg/log_check.hpp"
#include "hpr/msg/ticks.hpp"
#include "hpr/node/lcm_url.hpp"

namespace {

constexpr const char* kUsage = R"(usage: lcm_recorder FILE [options]
       lcm_recorder --check FILE

Records every LCM message (or those of --channel) into FILE until SIGINT or SIGTERM.
--check reads a log (any LCM log) and reports its messages per channel and the ticks its
data-flow channels lack.
  --lcm-url URL     LCM URL (default: $LCM_DEFAULT_URL, else LCM's default)
  --channel REGEX   channels to record (default .*)
  --queue N         messages held while the file is written (default 200000)
  --force           overwrite FILE
  --quiet           no progress line
Exit status: 0 recorded (--check: the log is complete), 1 error, 2 bad use, 3 ticks of data-flow
channels are missing, 4 (--check) the log holds messages that do not decode.
)";

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

/// What a log holds: messages and bytes per channel, and which ticks each data-flow channel has.
struct Tally {
  struct Count {
    std::int64_t messages = 0, bytes = 0;
  };
  void add(const std::string& channel, const void* data, int size) {
    Count& c = counts[channel];
    ++c.messages;
    c.bytes += size;
    ++messages;
    bytes += size;
    coverage.add(channel, hpr::msg::tick_of(data, size));
  }
  /// Prints the counts, then the ticks each data-flow channel lacks. Returns 3 when a channel
  /// lacks ticks, else 0.
  [[nodiscard]] int report() const {
    for (const auto& [c, n] : counts) {
      std::fprintf(stderr, "  %-20s %9lld messages %9.1f kB\n", c.c_str(), static_cast<long long>(n.messages), static_cast<double>(n.bytes) / 1e3);
    }
    const auto lacking = coverage.lacking();
    for (const auto& [c, ticks] : lacking) {
      std::fprintf(stderr, "lcm_recorder: %s: no message for %zu tick%s (%s), lost here or never published\n", c.c_str(), ticks.size(),
                   ticks.size() == 1 ? "" : "s", hpr::msg::tick_ranges(ticks).c_str());
    }
    if (lacking.empty()) std::fprintf(stderr, "lcm_recorder: every tick of the data-flow channels present\n");
    return lacking.empty() ? 0 : 3;
  }
  std::map<std::string, Count> counts;
  hpr::msg::TickCoverage coverage;
  std::int64_t messages = 0, bytes = 0;
};

class Recorder {
 public:
  explicit Recorder(lcm::LogFile& log) : log_(log) {}
  void on(const lcm::ReceiveBuffer* rb, const std::string& channel) {
    lcm::LogEvent ev{};
    ev.timestamp = rb->recv_utime;
    ev.channel = channel;
    ev.datalen = static_cast<int32_t>(rb->data_size);
    ev.data = rb->data;
    if (log_.writeEvent(&ev) != 0) ++write_errors;
    tally.add(channel, rb->data, ev.datalen);
  }
  Tally tally;
  std::int64_t write_errors = 0;

 private:
  lcm::LogFile& log_;
};

int check_log(const std::string& file) {
  lcm::LogFile log(file, "r");
  if (!log.good()) {
    std::fprintf(stderr, "lcm_recorder: cannot read %s\n", file.c_str());
    return 1;
  }
  Tally tally;
  std::int64_t bad = 0;
  long offset = std::ftell(log.getFilePtr());
  for (const lcm::LogEvent* ev = log.readNextEvent(); ev != nullptr; ev = log.readNextEvent()) {
    tally.add(ev->channel, ev->data, ev->datalen);
    // The same judgement as lcm_export's (hpr::msg::check_message).
    if (const std::string why = hpr::msg::check_message(ev->channel, ev->data, ev->datalen); !why.empty()) {
      if (++bad <= 10) {
        std::fprintf(stderr, "lcm_recorder: event %lld at byte %ld on %s: %s\n", static_cast<long long>(ev->eventnum), offset,
                     ev->channel.c_str(), why.c_str());
      }
    }
    offset = std::ftell(log.getFilePtr());
  }
  std::fprintf(stderr, "lcm_recorder: %s: %lld messages, %lld undecodable\n", file.c_str(), static_cast<long long>(tally.messages),
               static_cast<long long>(bad));
  const int ticks = tally.report();
  return bad > 0 ? 4 : ticks;
}

}  // namespace

int main(int argc, char** argv) {
  std::string file, url, channel = ".*";
  int queue = 200000;
  bool force = false, quiet = false;
  try {
    hpr::ArgReader args(argc, argv);
    while (args.next()) {
      if (args.is("-h", "--help")) {
        std::fputs(kUsage, stdout);
        return 0;
      } else if (args.is("--lcm-url")) {
        url = args.value();
      } else if (args.is("--channel")) {
        channel = args.value();
      } else if (args.is("--queue")) {
        queue = args.integer();
        if (queue < 1) throw std::invalid_argument("--queue: at least 1 message");
      } else if (args.is("--check")) {
        return check_log(args.value());
      } else if (args.is("--force", "-f")) {
        force = true;
      } else if (args.is("--quiet", "-q")) {
        quiet = true;
      } else if (args.positional() && file.empty()) {
        file = args.current();
      } else {
        args.unknown();
      }
    }
    if (file.empty()) throw std::invalid_argument("no FILE given");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lcm_recorder: %s\n\n%s", e.what(), kUsage);
    return 2;
  }
  if (!force && std::filesystem::exists(file)) {
    std::fprintf(stderr, "lcm_recorder: %s exists (--force overwrites it)\n", file.c_str());
    return 2;
  }
  url = hpr::node::with_receive_buffer(hpr::node::resolve_lcm_url(url, ""), hpr::node::kRecorderBufferBytes);
  lcm::LogFile log(file, "w");
  if (!log.good()) {
    std::fprintf(stderr, "lcm_recorder: cannot write %s\n", file.c_str());
    return 1;
  }
  std::unique_ptr<lcm::LCM> lcm_handle;
  try {
    lcm_handle = hpr::node::open_lcm(url);
  } catch (const hpr::node::LcmError& e) {
    std::fprintf(stderr, "lcm_recorder: %s\n", e.what());
    return 1;
  }
  lcm::LCM& lcm = *lcm_handle;
  Recorder rec(log);
  lcm.subscribe(channel, &Recorder::on, &rec)->setQueueCapacity(queue);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  if (!quiet) std::fprintf(stderr, "lcm_recorder: recording %s from %s (Ctrl-C to stop)\n", file.c_str(), url.c_str());
  const double t0 = hpr::monotonic_s();
  double next_progress = t0 + 2.0;
  while (g_stop == 0) {
    if (lcm.handleTimeout(100) < 0) {
      if (g_stop != 0) break;  // the stop signal interrupted the wait
      std::fprintf(stderr, "lcm_recorder: LCM failed while receiving\n");
      break;
    }
    if (!quiet && hpr::monotonic_s() >= next_progress) {
      std::fprintf(stderr, "\rlcm_recorder: %.0f s, %lld messages, %.1f MB", hpr::monotonic_s() - t0,
                   static_cast<long long>(rec.tally.messages), static_cast<double>(rec.tally.bytes) / 1e6);
      next_progress += 2.0;
    }
  }
  // What LCM still queues is part of the recording.
  while (lcm.handleTimeout(0) > 0) {
  }
  std::fflush(log.getFilePtr());
  std::fprintf(stderr, "%slcm_recorder: %lld messages (%.1f MB) in %.1f s into %s\n", !quiet && rec.tally.messages > 0 ? "\n" : "",
               static_cast<long long>(rec.tally.messages), static_cast<double>(rec.tally.bytes) / 1e6, hpr::monotonic_s() - t0, file.c_str());
  const int status = rec.tally.report();
  if (rec.write_errors > 0) {
    std::fprintf(stderr, "lcm_recorder: %lld messages could not be written to %s\n", static_cast<long long>(rec.write_errors), file.c_str());
    return 1;
  }
  return status;
}
