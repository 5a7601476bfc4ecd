// lcm_recorder: records LCM traffic into an LCM log file (the format of lcm-logger, read by
// lcm-logplayer, lcm-spy, tools/replay and lcm_export) without losing messages under load.
//
// lcm-logger keeps LCM's default subscription queue of 30 messages: with the whole stack at
// 1 kHz (about 8 messages per tick, more in lockstep) a logger held up for 4 ms loses messages.
// This recorder asks the kernel for a socket buffer of seconds of traffic (on a URL other than
// udpm://, liblcm's queue holds up to --queue messages too), and on exit says which ticks of the
// data-flow channels are missing, so that a log is known complete or known holed.
//
// On a udpm URL it reads the multicast socket itself (hpr/node/udpm.hpp) and stamps each message
// with the kernel's receive time: on the loopback, the instant it was published, however late
// the recorder woke. A recording's delays (lcm_latency) are then those of the stack, not of the
// recorder's scheduling.
//
// Exit status: 0 recorded (complete), 1 error, 2 bad use, 3 recorded with missing ticks, 4 (--check)
// undecodable messages in the log.
#include <fmt/format.h>

#include <poll.h>

#include <cerrno>
#include <csignal>
#include <filesystem>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <regex>
#include <string>
#include <string_view>

#include "hpr/common/args.hpp"
#include "hpr/common/time.hpp"
#include "hpr/msg/log_check.hpp"
#include "hpr/msg/ticks.hpp"
#include "hpr/node/lcm_url.hpp"
#include "hpr/node/udpm.hpp"

namespace {

constexpr const char* kUsage = R"(usage: lcm_recorder FILE [options]
       lcm_recorder --check FILE

Records every LCM message (or those of --channel) into FILE until SIGINT or SIGTERM.
--check reads a log (any LCM log) and reports its messages per channel and the ticks its
data-flow channels lack.
  --lcm-url URL     LCM URL (default: $LCM_DEFAULT_URL, else LCM's default)
  --channel REGEX   channels to record (default .*)
  --queue N         messages held while the file is written, for a URL other than udpm://
                    (default 200000; on udpm:// the socket's buffer of seconds of traffic holds them)
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
  Recorder(lcm::LogFile& log, const std::string& channels) : log_(log), channels_(channels) {}
  /// liblcm's subscription (it matched the channel already).
  void on(const lcm::ReceiveBuffer* rb, const std::string& channel) { write(channel, rb->data, rb->data_size, rb->recv_utime); }
  /// The own socket's message, when its channel matches (as liblcm does, the whole name).
  void offer(std::string_view channel, const void* data, std::size_t size, std::int64_t utime) {
    auto it = matches_.find(channel);
    if (it == matches_.end()) it = matches_.emplace(std::string(channel), std::regex_match(channel.begin(), channel.end(), channels_)).first;
    if (it->second) write(it->first, data, size, utime);
  }
  Tally tally;
  std::int64_t write_errors = 0;

 private:
  void write(const std::string& channel, const void* data, std::size_t size, std::int64_t utime) {
    lcm::LogEvent ev{};
    ev.timestamp = utime;
    ev.channel = channel;
    ev.datalen = static_cast<int32_t>(size);
    ev.data = const_cast<void*>(data);
    if (log_.writeEvent(&ev) != 0) ++write_errors;
    tally.add(channel, data, ev.datalen);
  }
  lcm::LogFile& log_;
  std::regex channels_;
  std::map<std::string, bool, std::less<>> matches_;
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
  std::unique_ptr<Recorder> rec_holder;
  try {
    rec_holder = std::make_unique<Recorder>(log, channel);
  } catch (const std::regex_error& e) {
    std::fprintf(stderr, "lcm_recorder: --channel '%s' is not a regular expression: %s\n", channel.c_str(), e.what());
    return 2;
  }
  Recorder& rec = *rec_holder;
  std::unique_ptr<lcm::LCM> lcm_handle;
  std::unique_ptr<hpr::node::UdpmReceiver> socket;
  try {
    if (hpr::node::is_udpm_url(url)) {
      hpr::node::check_multicast_route(url);
      socket = std::make_unique<hpr::node::UdpmReceiver>(hpr::node::parse_udpm_url(url));
    } else {
      lcm_handle = hpr::node::open_lcm(url);
      lcm_handle->subscribe(channel, &Recorder::on, &rec)->setQueueCapacity(queue);
    }
  } catch (const hpr::node::LcmError& e) {
    std::fprintf(stderr, "lcm_recorder: %s\n", e.what());
    return 1;
  }
  const hpr::node::MessageSink sink = [&rec](std::string_view ch, const std::uint8_t* data, std::size_t size, std::int64_t utime) {
    rec.offer(ch, data, size, utime);
  };
  // One turn of the loop: what is waiting, or a wait of at most `timeout_ms`. -1: failed.
  const auto receive = [&](int timeout_ms) -> int {
    if (lcm_handle) return lcm_handle->handleTimeout(timeout_ms);
    pollfd p{socket->fd(), POLLIN, 0};
    const int n = ::poll(&p, 1, timeout_ms);
    if (n <= 0) return n < 0 && errno != EINTR ? -1 : 0;
    return static_cast<int>(socket->drain(sink));
  };
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  if (!quiet) std::fprintf(stderr, "lcm_recorder: recording %s from %s (Ctrl-C to stop)\n", file.c_str(), url.c_str());
  const double t0 = hpr::monotonic_s();
  double next_progress = t0 + 2.0;
  while (g_stop == 0) {
    if (receive(100) < 0) {
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
  // What is still queued is part of the recording.
  while (receive(0) > 0) {
  }
  if (socket && socket->refused() > 0) {
    std::fprintf(stderr, "lcm_recorder: %lld datagrams were not LCM's format (the last: %s)\n", static_cast<long long>(socket->refused()),
                 socket->last_refusal().c_str());
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
