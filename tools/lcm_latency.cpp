// lcm_latency: the control chain's delay per tick, from a recording of a running stack: the time
// from ROBOT_SENSORS of tick k to JOINT_COMMAND of tick k, as the recorder received them (one
// receive clock for every channel), and each hop's share: the estimator (ROBOT_SENSORS → ROBOT_STATE),
// the reference generator (→ CAM_REFERENCE), the motion optimiser (→ WHOLEBODY_COMMAND) and the wbc
// (→ JOINT_COMMAND); without the CAM channels, the wbc's hop starts at ROBOT_STATE. The composed
// controllers (one process) publish JOINT_COMMAND first: their delay has no hops to tell apart.
//
//   lcm_latency LOG [--json FILE]
//
// Median, p99 and max per hop over the ticks that have every channel of the chain. The times are
// the recorder's receive times, so the recorder must read each message as it arrives: run it above
// the chain's real-time priority (chrt -f 95 tools/record). One the scheduler holds back reads
// several messages in one burst and stamps them alike (hops of a few microseconds). Meaningful
// for a real-time run (tools/supervisor up sim); in lockstep the times measure how fast the chain
// runs, not a deadline.
#include <fmt/format.h>

#include <cstdio>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <set>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "hpr/common/args.hpp"
#include "hpr/common/stats.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/log_check.hpp"
#include "hpr/msg/ticks.hpp"

namespace {

namespace channels = hpr::msg::channels;

void usage(std::FILE* out) {
  std::fputs("usage: lcm_latency LOG [--json FILE]\n\n"
             "The delay from ROBOT_SENSORS(k) to JOINT_COMMAND(k) per tick in a recording, and each hop's share\n"
             "(estimator, reference_gen, motion_opt, wbc; for the ankle strategy estimator, planner, wbc):\n"
             "median, p99, max [us]. Record above the chain's real-time priority (chrt -f 95 tools/record),\n"
             "so that each message is stamped as it arrives.\n",
             out);
}

}  // namespace

int main(int argc, char** argv) {
  std::string log_path, json_path;
  const auto usage_error = hpr::read_command_line(
      argc, argv, "lcm_latency", usage,
      [&](hpr::ArgReader& args) {
        if (args.is("--json")) {
          json_path = args.value();
        } else if (args.positional() && log_path.empty()) {
          log_path = args.current();
        } else {
          args.unknown();
        }
      },
      [&] {
        if (log_path.empty()) throw hpr::UsageError("need LOG");
      });
  if (usage_error) return *usage_error;
  lcm::LogFile log(log_path, "r");
  if (!log.good()) {
    std::fprintf(stderr, "lcm_latency: cannot open %s\n", log_path.c_str());
    return 1;
  }
  // The chain's channels (a logged channel may carry a prefix: "robotA/ROBOT_STATE").
  const std::set<std::string> chain = {channels::kRobotSensors.name, channels::kRobotState.name, channels::kCamReference.name,
                                       channels::kWholebodyCommand.name, channels::kJointCommand.name};
  // channel → tick → first receive time [us] (a republished tick counts from its first copy).
  std::map<std::string, std::map<std::int64_t, std::int64_t>> seen;
  long bad = 0;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    std::string name;
    channels::with_channel(e->channel, [&](const auto& c) { name = c.name; });
    if (chain.count(name) == 0) continue;
    if (!hpr::msg::check_message(e->channel, e->data, e->datalen).empty()) {
      ++bad;
      continue;
    }
    seen[name].emplace(hpr::msg::tick_of(e->data, e->datalen), e->timestamp);
  }
  const bool cam = !seen[channels::kCamReference.name].empty() && !seen[channels::kWholebodyCommand.name].empty();
  std::vector<std::string> path = {channels::kRobotSensors.name, channels::kRobotState.name};
  // The planner runs beside reference_gen: on the path of the ankle strategy only (with the CAM
  // strategy, motion_opt's hop starts at CAM_REFERENCE and waits for whichever comes last).
  if (cam) {
    path.insert(path.end(), {channels::kCamReference.name, channels::kWholebodyCommand.name});
  } else if (!seen[channels::kBalancePlan.name].empty()) {
    path.push_back(channels::kBalancePlan.name);
  }
  path.push_back(channels::kJointCommand.name);
  const std::map<std::string, std::string> hop_name = {{channels::kRobotState.name, "estimator"},
                                                       {channels::kBalancePlan.name, "planner"},
                                                       {channels::kCamReference.name, "reference_gen"},
                                                       {channels::kWholebodyCommand.name, "motion_opt"},
                                                       {channels::kJointCommand.name, "wbc"}};
  std::vector<std::vector<double>> hops(path.size() - 1);
  std::vector<double> total;
  for (const auto& [tick, t0] : seen[channels::kRobotSensors.name]) {
    std::vector<std::int64_t> t = {t0};
    for (size_t i = 1; i < path.size(); ++i) {
      const auto& m = seen[path[i]];
      const auto it = m.find(tick);
      if (it == m.end()) break;
      t.push_back(it->second);
    }
    if (t.size() != path.size()) continue;
    for (size_t i = 0; i + 1 < t.size(); ++i) hops[i].push_back(static_cast<double>(t[i + 1] - t[i]));
    total.push_back(static_cast<double>(t.back() - t.front()));
  }
  if (total.empty()) {
    std::fprintf(stderr, "lcm_latency: no tick of %s has every channel of the chain (%s)\n", log_path.c_str(),
                 fmt::format("{}", fmt::join(path, " -> ")).c_str());
    return 1;
  }
  nlohmann::ordered_json j;
  j["log"] = log_path;
  j["ticks"] = total.size();
  j["undecodable_events"] = bad;
  std::printf("%s: %zu ticks with every channel of the chain%s\n", log_path.c_str(), total.size(),
              bad > 0 ? fmt::format(" ({} undecodable events skipped)", bad).c_str() : "");
  std::printf("%-50s %10s %10s %10s  [us]\n", "", "median", "p99", "max");
  const auto row = [&](const std::string& name, const std::vector<double>& v, const std::string& key) {
    const double med = hpr::percentile(v, 0.5), p99 = hpr::percentile(v, 0.99), mx = hpr::percentile(v, 1.0);
    std::printf("%-50s %10.1f %10.1f %10.1f\n", name.c_str(), med, p99, mx);
    j[key] = {{"median_us", med}, {"p99_us", p99}, {"max_us", mx}};
  };
  // The composed controllers publish JOINT_COMMAND before the channels on the way to it: their
  // outputs are one step, with no hops to tell apart.
  const bool composed = hpr::percentile(hops.back(), 0.5) < 0;
  j["one_process"] = composed;
  if (composed) {
    std::printf("(JOINT_COMMAND is published before %s: the chain runs in one process, no hops to tell apart)\n",
                path[path.size() - 2].c_str());
  } else {
    for (size_t i = 0; i < hops.size(); ++i) {
      row(fmt::format("{} ({} -> {})", hop_name.at(path[i + 1]), path[i], path[i + 1]), hops[i], hop_name.at(path[i + 1]));
    }
  }
  row("ROBOT_SENSORS(k) -> JOINT_COMMAND(k)", total, "total");
  if (!json_path.empty()) std::ofstream(json_path) << j.dump(2) << "\n";
  return 0;
}
