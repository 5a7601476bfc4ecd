// replay_check: re-runs chosen nodes on the inputs recorded in an LCM log and compares their
// outputs with the recorded ones, channel by channel.
//
// The nodes run on a private LCM URL. Every channel a re-run node publishes is held back from the
// playback and, where the log has it, compared with what the re-run node publishes for the same
// tick (wall-clock fields cleared). A recorded output waits for the re-run's, so the playback is
// paced by the nodes (lockstep), and a lockstep log must reproduce exactly.
//
// The log is played in data-flow order (by tick, then sensors, state, CAM reference, whole-body
// command, joint command, balance status), which the recorded order of a loaded machine need not
// be. A second recorded message for a tick already compared came from a wall-clock event of the
// recorded run (a node reporting an input as stale while it waited); it is counted under REPEATS
// and not compared.
//
// A log that lacks a tick of a played input (the recorder lost messages while the machine held it
// up) cannot reproduce past that tick: the check says which ticks are lacking, compares the
// outputs before the first of them only, and ends with exit status 3.
#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/health_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include <algorithm>
#include <deque>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <functional>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "hpr/common/args.hpp"
#include "hpr/common/time.hpp"
#include "hpr/launch/process_group.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/graph/data_flow.hpp"
#include "hpr/msg/log_check.hpp"
#include "hpr/msg/ticks.hpp"
#include "hpr/node/lcm_url.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/common/auth.hpp"

namespace fs = std::filesystem;

namespace {

constexpr const char* kUsage = R"(replay_check: re-run nodes on a log's recorded inputs and compare their outputs

usage: replay_check LOG --nodes NAME[,NAME...] [options]
  --nodes LIST      nodes to re-run: estimator, planner, wbc, reference_gen, motion_opt, or
                    controllers (the five composed in one process, compared on all their channels)
  --config FILE     the configuration the log was recorded with (default: config/toro.yaml)
  --set key=value   an override the log was recorded with (repeatable; e.g. balance.support=double)
  --timeout S       wall seconds to wait for one output before calling it missing (default 5)
  --json FILE       the report as JSON
  --work-dir DIR    the re-run nodes' logs (default: a temporary folder)
The re-run nodes are fed by this tool, whose pauses (a loaded machine) are not a sensor dropout:
they run with estimator.sensor_timeout=60, so that a pause never makes them step on a stale state
(a dropout in the recording itself shows as a difference).
Exit status: 0 when every compared output matches and none is missing, 1 otherwise, 2 on bad use,
3 when the log lacks ticks of a played input (the outputs before the first gap are compared).
)";

/// What a node publishes (the channels compared), from the stack's declared data flow.
std::vector<std::string> outputs_of(const std::string& node) {
  static const std::set<std::string> kRerunnable = {"estimator", "planner", "wbc", "reference_gen", "motion_opt", "controllers"};
  const hpr::Ports* p = hpr::graph::find_process(node);
  if (p == nullptr || kRerunnable.count(node) == 0) {
    throw std::invalid_argument("unknown node '" + node + "' (estimator, planner, wbc, reference_gen, motion_opt, controllers)");
  }
  return {p->writes.begin(), p->writes.end()};
}
/// Channels never played back (each process publishes its own).
const std::set<std::string> kNotPlayed = {hpr::msg::channels::kHealth.name, hpr::msg::channels::kParams.name,
                                          hpr::msg::channels::kSupervisorStatus.name, hpr::msg::channels::kSupervisorCommand.name};

/// Decodes, clears the wall-clock fields (and the publisher's identity and code), re-encodes: two outputs are equal when these bytes are.
using Canonical = std::function<std::vector<uint8_t>(const void*, int)>;

template <class Msg>
Canonical canonical(std::function<void(Msg&)> clear) {
  return [clear](const void* data, int size) {
    Msg m;
    if (m.decode(data, 0, size) < 0) return std::vector<uint8_t>{};
    clear(m);
    // Who published it (a process's random identity) and its authentication code (over that) are
    // not what the node computed.
    if constexpr (hpr::node::Sourced<Msg>) m.source = 0;
    if constexpr (hpr::auth::Signed<Msg>) std::fill(std::begin(m.mac), std::end(m.mac), std::uint8_t{0});
    std::vector<uint8_t> out(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(out.data(), 0, static_cast<int>(out.size()));
    return out;
  };
}

const std::map<std::string, Canonical>& canonicals() {
  static const std::map<std::string, Canonical> k = {
      {hpr::msg::channels::kRobotState.name, canonical<humanoid::robot_state_t>([](auto&) {})},  // utime is the sensor sample's robot clock
      {hpr::msg::channels::kJointCommand.name, canonical<humanoid::joint_command_t>([](auto&) {})},  // utime: the state's robot clock
      {hpr::msg::channels::kBalanceStatus.name, canonical<humanoid::balance_status_t>([](auto& m) {
         m.utime = 0;
         m.qp_solve_time_us = 0;
         m.compute_time_us = 0;
       })},
      {hpr::msg::channels::kBalancePlan.name, canonical<humanoid::balance_plan_t>([](auto&) {})},  // utime: the state's robot clock
      {hpr::msg::channels::kCamReference.name, canonical<humanoid::cam_reference_t>([](auto& m) { m.utime = 0; })},
      {hpr::msg::channels::kWholebodyCommand.name, canonical<humanoid::wholebody_command_t>([](auto& m) {
         m.utime = 0;
         m.qp_solve_time_us = 0;
       })},
  };
  return k;
}

struct Event {
  std::string channel;
  std::vector<uint8_t> data;
  std::int64_t tick = -1;
  int rank = hpr::msg::kNotInFlow;
};

/// The log's messages in data-flow order: by tick, then by position in the tick's flow, else as
/// recorded. The recorded order alone is not causal: on a loaded machine the logger receives
/// messages from several processes out of order (a tick's ROBOT_STATE before its ROBOT_SENSORS).
std::vector<Event> read_in_flow_order(lcm::LogFile& log) {
  std::vector<Event> events;
  std::int64_t current = 0;  // the tick of the flow so far, for channels outside it
  for (const lcm::LogEvent* ev = log.readNextEvent(); ev != nullptr; ev = log.readNextEvent()) {
    if (kNotPlayed.count(ev->channel) != 0) continue;
    Event e;
    e.channel = ev->channel;
    const auto* d = static_cast<const uint8_t*>(ev->data);
    e.data.assign(d, d + ev->datalen);
    e.rank = hpr::msg::flow_rank(e.channel);
    if (e.rank != hpr::msg::kNotInFlow) {
      e.tick = hpr::msg::tick_of(ev->data, ev->datalen);
      current = std::max(current, e.tick);
    } else {
      e.tick = current;
    }
    events.push_back(std::move(e));
  }
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) {
    return a.tick != b.tick ? a.tick < b.tick : a.rank < b.rank;
  });
  return events;
}

struct Raw {
  std::vector<uint8_t> data;
  std::int64_t tick = -1;
};

class Outputs {
 public:
  Outputs(lcm::LCM& lcm, const std::vector<std::string>& channels) {
    // Every output is compared: no message may be dropped while the playback publishes.
    for (const auto& c : channels) lcm.subscribe(c, &Outputs::on, this)->setQueueCapacity(hpr::node::kCountingQueueCapacity);
  }
  std::map<std::string, std::deque<Raw>> queues;

 private:
  void on(const lcm::ReceiveBuffer* rb, const std::string& channel) {
    Raw r;
    r.data.assign(static_cast<const uint8_t*>(rb->data), static_cast<const uint8_t*>(rb->data) + rb->data_size);
    r.tick = hpr::msg::tick_of(rb->data, static_cast<int>(rb->data_size));
    queues[channel].push_back(std::move(r));
  }
};

/// The nodes heard from on HEALTH while it lives.
class HealthSeen {
 public:
  explicit HealthSeen(lcm::LCM& lcm) : lcm_(lcm), subscription_(lcm.subscribe(hpr::msg::channels::kHealth.name, &HealthSeen::on, this)) {}
  ~HealthSeen() { lcm_.unsubscribe(subscription_); }
  HealthSeen(const HealthSeen&) = delete;
  HealthSeen& operator=(const HealthSeen&) = delete;
  std::set<std::string> nodes;

 private:
  lcm::LCM& lcm_;
  lcm::Subscription* subscription_;
  void on(const lcm::ReceiveBuffer*, const std::string&, const humanoid::health_t* h) { nodes.insert(h->node); }
};

struct ChannelReport {
  std::int64_t compared = 0, equal = 0, different = 0, missing = 0;
  std::int64_t repeats = 0;  ///< recorded messages of a tick already compared (see below)
  std::int64_t unrecorded = 0;  ///< re-run outputs on a channel the log has none of
  std::int64_t last_tick = -1, first_difference_tick = -1, first_missing_tick = -1;
  std::size_t first_difference_byte = 0;
};

/// What the command line asks for.
struct ReplayOptions {
  std::string log_path, config, json_path, work;
  std::vector<std::string> nodes, sets;
  double timeout = 5.0;
};

/// The options, or the exit status when the command line is refused or asked for help.
std::optional<int> read_options(int argc, char** argv, ReplayOptions& o) {
  try {
    hpr::ArgReader args(argc, argv);
    while (args.next()) {
      if (args.is("-h", "--help")) {
        std::cout << kUsage;
        return 0;
      } else if (args.is("--nodes")) {
        o.nodes = args.list();
      } else if (args.is("--config")) {
        o.config = args.value();
      } else if (args.is("--set")) {
        o.sets.push_back(args.value());
      } else if (args.is("--timeout")) {
        o.timeout = args.number();
      } else if (args.is("--json")) {
        o.json_path = args.value();
      } else if (args.is("--work-dir")) {
        o.work = args.value();
      } else if (args.positional() && o.log_path.empty()) {
        o.log_path = args.current();
      } else {
        args.unknown();
      }
    }
    if (o.log_path.empty()) throw std::invalid_argument("no LOG given");
    if (o.nodes.empty()) throw std::invalid_argument("--nodes is required");
    for (const auto& n : o.nodes) (void)outputs_of(n);
  } catch (const std::exception& e) {
    std::cerr << "replay_check: " << e.what() << "\n\n" << kUsage;
    return 2;
  }
  if (o.config.empty()) {
    const fs::path exe = hpr::launch::executable_dir();
    for (const fs::path& c : {exe / "../../config/toro.yaml", exe / "../share/hpr/config/toro.yaml"}) {
      if (fs::exists(c)) o.config = fs::weakly_canonical(c).string();
    }
  }
  if (!fs::exists(o.log_path)) {
    std::cerr << "replay_check: no log file " << o.log_path << "\n";
    return 2;
  }
  if (o.work.empty()) o.work = (fs::temp_directory_path() / fmt::format("hpr-replay-{}", ::getpid())).string();
  fs::create_directories(o.work);
  return std::nullopt;
}

/// Starts the re-run nodes on the group's private LCM and waits for each one's HEALTH; false
/// (having said which and where its log is) when one does not come up within 20 s.
bool start_nodes(hpr::launch::ProcessGroup& group, lcm::LCM& lcm, const ReplayOptions& o) {
  HealthSeen health(lcm);
  // A recording's commands are as old as the recording: their freshness is not checked in a re-run
  // (on its private LCM URL, never a robot's).
  std::vector<std::string> node_args = {"--config", o.config, "--set", "estimator.sensor_timeout=60", "--set", "lcm.command_window_s=0"};
  for (const auto& s : o.sets) node_args.insert(node_args.end(), {"--set", s});
  for (const auto& n : o.nodes) group.start(n, node_args, {}, o.work + "/" + n + ".log");
  const double ready_by = hpr::monotonic_s() + 20.0;
  while (hpr::monotonic_s() < ready_by && health.nodes.size() < o.nodes.size()) lcm.handleTimeout(50);
  for (const auto& n : o.nodes) {
    if (health.nodes.count(n) == 0) {
      std::cerr << "replay_check: " << n << " did not start (no HEALTH within 20 s); see " << o.work << "/" << n << ".log\n";
      return false;
    }
  }
  return true;
}

/// The first tick from which a played input is missing from the log (none: the largest tick),
/// saying which ticks each channel lacks.
std::int64_t first_gap_of(const std::vector<Event>& flow, const std::set<std::string>& outputs,
                          std::map<std::string, std::vector<std::int64_t>>& lacking) {
  hpr::msg::TickCoverage coverage;
  for (const Event& ev : flow) {
    if (outputs.count(ev.channel) == 0) coverage.add(ev.channel, ev.tick);
  }
  lacking = coverage.lacking();
  std::int64_t first_gap = std::numeric_limits<std::int64_t>::max();
  for (const auto& [channel, ticks] : lacking) {
    std::cout << fmt::format("the log lacks {} of {} tick{} ({}): the recorder lost them\n", channel, ticks.size(),
                             ticks.size() == 1 ? "" : "s", hpr::msg::tick_ranges(ticks));
    first_gap = std::min(first_gap, ticks.front());
  }
  if (!lacking.empty()) std::cout << fmt::format("comparing the outputs before tick {} only\n", first_gap);
  return first_gap;
}

/// A recorded output against the re-run's of the same tick (waited for up to `timeout` s).
void compare(const Event& recorded, std::deque<Raw>& rerun, lcm::LCM& lcm, double timeout, ChannelReport& r) {
  const std::int64_t tick = recorded.tick;
  if (tick == r.last_tick) {
    // A second message for a tick: published on a wall-clock event of the recorded run (the
    // estimator's report of stale sensors while it waited), which no replay can reproduce.
    ++r.repeats;
    return;
  }
  r.last_tick = tick;
  const double give_up = hpr::monotonic_s() + timeout;
  bool found = false;
  while (true) {
    while (!rerun.empty() && rerun.front().tick < tick) rerun.pop_front();  // outputs the log lacks
    if (!rerun.empty()) {
      found = rerun.front().tick == tick;
      break;
    }
    if (hpr::monotonic_s() > give_up) break;
    lcm.handleTimeout(10);
  }
  if (!found) {
    ++r.missing;
    if (r.first_missing_tick < 0) r.first_missing_tick = tick;
    return;
  }
  const Raw got = std::move(rerun.front());
  rerun.pop_front();
  const auto& canon = canonicals().at(recorded.channel);
  const auto a = canon(recorded.data.data(), static_cast<int>(recorded.data.size()));
  const auto b = canon(got.data.data(), static_cast<int>(got.data.size()));
  ++r.compared;
  if (!a.empty() && a == b) {
    ++r.equal;
    return;
  }
  ++r.different;
  if (r.first_difference_tick < 0) {
    r.first_difference_tick = tick;
    std::size_t k = 0;
    while (k < a.size() && k < b.size() && a[k] == b[k]) ++k;
    r.first_difference_byte = k;
  }
}

/// The table on stdout, the JSON report; whether every output matched.
bool report_on(const ReplayOptions& o, const std::vector<std::string>& outputs, std::map<std::string, ChannelReport>& report,
               std::int64_t played, const std::map<std::string, std::vector<std::int64_t>>& lacking, std::int64_t first_gap) {
  bool ok = true, any_compared = false;
  nlohmann::ordered_json j;
  j["log"] = o.log_path;
  j["nodes"] = o.nodes;
  j["played"] = played;
  std::cout << fmt::format("{:<20} {:>9} {:>9} {:>9} {:>8} {:>8}  {}\n", "CHANNEL", "COMPARED", "EQUAL", "DIFFERENT", "MISSING", "REPEATS",
                           "FIRST DIFFERENCE");
  for (const auto& c : outputs) {
    const ChannelReport r = report[c];
    // A channel neither recorded nor re-run (the ankle strategy's CAM_REFERENCE, say) agrees.
    const bool absent = r.compared == 0 && r.missing == 0;
    const bool channel_ok = r.different == 0 && r.missing == 0 && (absent ? r.unrecorded == 0 : r.compared > 0);
    ok = ok && channel_ok;
    any_compared = any_compared || r.compared > 0;
    std::string first = "-";
    if (r.first_difference_tick >= 0) first = fmt::format("tick {} (byte {})", r.first_difference_tick, r.first_difference_byte);
    if (r.first_missing_tick >= 0) first += fmt::format("; first missing at tick {}", r.first_missing_tick);
    if (absent) first = r.unrecorded == 0 ? "not in the log, nor re-run" : fmt::format("not in the log; the re-run published {}", r.unrecorded);
    std::cout << fmt::format("{:<20} {:>9} {:>9} {:>9} {:>8} {:>8}  {}\n", c, r.compared, r.equal, r.different, r.missing, r.repeats, first);
    j["channels"][c] = {{"compared", r.compared}, {"equal", r.equal},       {"different", r.different},
                        {"missing", r.missing},   {"repeats", r.repeats}, {"first_difference_tick", r.first_difference_tick},
                        {"unrecorded", r.unrecorded}, {"match", channel_ok}};
  }
  ok = ok && any_compared;
  j["match"] = ok;
  j["complete"] = lacking.empty();
  for (const auto& [channel, ticks] : lacking) j["lacking"][channel] = ticks;
  if (!lacking.empty()) j["compared_before_tick"] = first_gap;
  std::cout << (ok ? "replay matches the recording" : "replay DIFFERS from the recording")
            << (lacking.empty() ? "\n" : fmt::format(" before tick {}; the log lacks inputs from there on\n", first_gap));
  if (!o.json_path.empty()) std::ofstream(o.json_path) << j.dump(2) << "\n";
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  ReplayOptions o;
  if (const auto status = read_options(argc, argv, o)) return *status;
  std::vector<std::string> outputs;
  for (const auto& n : o.nodes) {
    for (const auto& c : outputs_of(n)) outputs.push_back(c);
  }
  const std::set<std::string> output_set(outputs.begin(), outputs.end());

  hpr::launch::ProcessGroup group;
  std::unique_ptr<lcm::LCM> lcm_handle;
  try {
    lcm_handle = hpr::node::open_lcm(group.lcm_url());
  } catch (const hpr::node::LcmError& e) {
    std::cerr << "replay_check: " << e.what() << "\n";
    return 1;
  }
  lcm::LCM& lcm = *lcm_handle;
  Outputs out(lcm, outputs);
  if (!start_nodes(group, lcm, o)) return 1;
  for (auto& [c, q] : out.queues) q.clear();  // nothing before the first input counts

  lcm::LogFile log(o.log_path, "r");
  if (!log.good()) {
    std::cerr << "replay_check: cannot read " << o.log_path << "\n";
    return 2;
  }
  std::cerr << fmt::format("replay_check: re-running {} on {} (outputs compared: {})\n", fmt::join(o.nodes, ", "), o.log_path,
                           fmt::join(outputs, ", "));
  std::vector<Event> flow = read_in_flow_order(log);
  // The played inputs' codes were made with the key of the deployment that recorded the log: they
  // are signed again with this one's, which the re-run nodes check (a log from another machine
  // re-runs too). Nothing else in the played bytes changes.
  const hpr::auth::Key key = hpr::auth::load_or_create_key(group.key_path());
  for (Event& ev : flow) {
    if (output_set.count(ev.channel) == 0 && hpr::msg::carries_code(ev.channel) && ev.data.size() >= hpr::auth::kTagBytes) {
      hpr::auth::sign(ev.data.data(), ev.data.size(), ev.channel, key);
    }
  }
  // Played inputs the log lacks for a tick: nothing from that tick on can reproduce.
  std::map<std::string, std::vector<std::int64_t>> lacking;
  const std::int64_t first_gap = first_gap_of(flow, output_set, lacking);
  std::map<std::string, ChannelReport> report;
  std::int64_t played = 0, events = 0;
  double next_progress = hpr::monotonic_s() + 2.0;
  for (const Event& ev : flow) {
    if (ev.tick >= first_gap) break;
    ++events;
    if (output_set.count(ev.channel) == 0) {
      lcm.publish(ev.channel, ev.data.data(), static_cast<unsigned>(ev.data.size()));
      ++played;
      while (lcm.handleTimeout(0) > 0) {
      }
      continue;
    }
    // A recorded output: wait for the re-run's of the same tick.
    compare(ev, out.queues[ev.channel], lcm, o.timeout, report[ev.channel]);
    if (hpr::monotonic_s() >= next_progress) {
      std::cerr << fmt::format("  tick {}: {} events, {} played\n", ev.tick, events, played);
      next_progress = hpr::monotonic_s() + 2.0;
    }
  }
  // What the re-run published on a channel the log has nothing of.
  const double settle = hpr::monotonic_s() + 0.2;
  while (hpr::monotonic_s() < settle) lcm.handleTimeout(10);
  for (const auto& c : outputs) {
    ChannelReport& r = report[c];
    if (r.compared == 0 && r.missing == 0) r.unrecorded = static_cast<std::int64_t>(out.queues[c].size());
  }
  group.stop_all();
  if (!report_on(o, outputs, report, played, lacking, first_gap)) return 1;
  return lacking.empty() ? 0 : 3;
}
