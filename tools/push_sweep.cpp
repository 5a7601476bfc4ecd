// push_sweep: the push envelope. For each direction, support and strategy, the largest impulse the
// robot recovers (push_trial's criteria), found by bracketing and bisection to a resolution
// (largest_recovered: the start, the cap, ×1.5 steps, bisection); in process, each case's trials
// continue one run from just before the push (PrePushCheckpoint); the cases run on this machine
// or as a Slurm job array (--executor, executor.hpp); a progress line per trial; a JSON table and
// a polar plot (largest recovered impulse per direction, CAM against ankle).
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "hpr/common/args.hpp"
#include "hpr/experiments/executor.hpp"
#include "hpr/experiments/version.hpp"
#include "hpr/launch/process_group.hpp"

namespace {

using namespace hpr::experiments;
namespace fs = std::filesystem;

void usage(std::FILE* out) {
  std::fprintf(out, R"(usage: push_sweep [options]

  --supports LIST         comma-separated: double,left,right (default double)
  --strategies LIST       comma-separated: cam,ankle (default cam,ankle)
  --directions N          N directions evenly spaced from 0 deg (default 8)
  --angles LIST           explicit directions in degrees (instead of --directions)
  --start NS              first impulse tried [N s] (default 15)
  --max-impulse NS        largest impulse tried [N s] (default 80)
  --resolution NS         bisection resolution [N s] (default 0.5)
  --out DIR               where sweep.json, sweep.png and the trials go (default sweep-<date>)

A trial that ends before it can tell (the stack failed, or a loaded machine held it past its time
limit) is run again, up to 3 times; one that stays inconclusive counts as not recovered, is marked
in the table and the JSON, and the exit status is 3. A case whose cluster task failed twice is
reported as failed with the trials it finished, never as a fall: exit status 4. Exit status 0
otherwise, 2 for bad arguments, 130 when interrupted (Ctrl-C; --resume goes on from there).

Where the cases run:
)");
  std::fputs(kExecutorOptionsUsage, out);
  std::fputs("\nThe push and the robot (every trial):\n", out);
  std::fputs(kPushOptionsUsage, out);
}

struct Case {
  std::string support;
  Strategy strategy = Strategy::kCam;
  double direction = 0.0;
  double max_recovered = 0.0;
  double min_lost = 0.0;  ///< the smallest impulse tried that was not recovered (0: none, reached_max)
  bool reached_max = false;
  bool inconclusive = false;  ///< a trial stayed inconclusive: the largest impulse may be too low
  bool failed = false;        ///< the case did not finish (a cluster task failed twice)
  std::string failure;
  struct Trial {
    double impulse;
    bool recovered, inconclusive;
  };
  std::vector<Trial> trials;
};

}  // namespace

int main(int argc, char** argv) {
  TrialSpec base;
  base.config = "toro";
  base.stop_when_decided = true;
  std::vector<std::string> supports = {"double"}, strategies = {"cam", "ankle"};
  std::vector<double> angles;
  int directions = 8;
  ExecutorOptions executor;
  double start = 15.0, max_impulse = 80.0, resolution = 0.5;
  std::string out_dir;
  const auto option = [&](hpr::ArgReader& args) {
    if (args.is("--supports")) {
      supports = args.list();
    } else if (args.is("--strategies")) {
      strategies = args.list();
    } else if (args.is("--directions")) {
      directions = args.integer();
      if (directions < 1) throw hpr::UsageError("--directions: at least 1");
    } else if (args.is("--angles")) {
      for (const auto& s : args.list()) angles.push_back(hpr::parse_number(s, "--angles"));
    } else if (args.is("--start")) {
      start = args.number();
    } else if (args.is("--max-impulse")) {
      max_impulse = args.number();
    } else if (args.is("--resolution")) {
      resolution = args.number();
    } else if (args.is("--out")) {
      out_dir = args.value();
    } else if (!executor.read(args) && !read_push_option(args, base)) {
      args.unknown();
    }
  };
  const auto check = [&] {
    executor.validate();
    if (executor.resume && out_dir.empty()) throw hpr::UsageError("--resume needs --out DIR");
    if (base.truth_state && !base.in_process) throw std::invalid_argument("--truth-state needs --in-process");
    base.config = find_config(base.config);
    for (const auto& s : strategies) (void)strategy_from_string(s);
    if (angles.empty()) {
      for (int d = 0; d < directions; ++d) angles.push_back(360.0 * d / directions);
    }
    if (!(resolution > 0) || !(start > 0) || !(max_impulse > start) || !(base.peak > 0)) {
      throw std::invalid_argument("need 0 < --start < --max-impulse, --resolution > 0 and --peak > 0");
    }
  };
  if (const auto status = hpr::read_command_line(argc, argv, "push_sweep", usage, option, check)) return *status;
  if (out_dir.empty()) out_dir = dated_name("sweep");
  fs::create_directories(out_dir);

  std::vector<Case> cases;
  for (const auto& s : supports) {
    for (const auto& st : strategies) {
      for (double d : angles) {
        Case c;
        c.support = s;
        c.strategy = strategy_from_string(st);
        c.direction = d;
        cases.push_back(c);
      }
    }
  }
  // The cases direction by direction (the strategies of one direction side by side: the costly
  // directions are spread over the run, not left to its end).
  std::vector<size_t> order(cases.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return cases[a].direction < cases[b].direction; });
  std::vector<SearchSpec> searches;
  for (const size_t i : order) {
    SearchSpec search;
    search.base = base;
    search.base.support = cases[i].support;
    search.base.strategy = cases[i].strategy;
    search.base.direction_deg = cases[i].direction;
    search.start = start;
    search.max_impulse = max_impulse;
    search.resolution = resolution;
    searches.push_back(search);
  }

  int trials_done = 0;
  const auto t0 = std::chrono::steady_clock::now();
  ExecutorEvents events;
  events.trial = [&](const SearchSpec& s, const TrialOutcome& t, bool stored) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "[%4d, %6.0f s] %-6s %-5s %5.1f deg %6.2f N s: %s%s\n", ++trials_done, elapsed, s.base.support.c_str(),
                 to_string(s.base.strategy), s.base.direction_deg, t.impulse,
                 t.result.recovered ? "recovered" : ("not recovered (" + t.result.failure + ")").c_str(), stored ? " [stored]" : "");
  };
  events.search = [&](const SearchSpec& s, const SearchResult& r) {
    if (r.failed) {
      std::fprintf(stderr, "  => %s: FAILED, %s\n", s.label().c_str(), r.failure.c_str());
      return;
    }
    std::fprintf(stderr, "  => %s %s %.0f deg: largest recovered impulse %.2f N s%s\n", s.base.support.c_str(),
                 to_string(s.base.strategy), s.base.direction_deg, r.bracket.max_recovered,
                 r.bracket.reached_max ? " (the maximum tried)" : "");
  };
  events.note = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  std::vector<SearchResult> results;
  std::string executor_text;
  try {
    const auto run = make_executor(executor, out_dir, events);
    executor_text = run->describe();
    std::fprintf(stderr, "push_sweep: %zu cases, %s; trials in %s\n", cases.size(), executor_text.c_str(),
                 executor.kind == "slurm" ? (executor.shared_dir ? *executor.shared_dir : out_dir + "/slurm").c_str() : (out_dir + "/trials").c_str());
    results = run->run(searches);
  } catch (const Interrupted& e) {
    std::fprintf(stderr, "push_sweep: %s\n", e.what());
    return 130;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "push_sweep: %s\n", e.what());
    return 1;
  }
  for (size_t k = 0; k < order.size(); ++k) {
    Case& c = cases[order[k]];
    const SearchResult& r = results[k];
    c.max_recovered = r.bracket.max_recovered;
    c.min_lost = r.bracket.min_lost;
    c.reached_max = r.bracket.reached_max;
    c.inconclusive = r.inconclusive;
    c.failed = r.failed;
    c.failure = r.failure;
    for (const auto& t : r.trials) c.trials.push_back({t.impulse, t.result.recovered, t.result.inconclusive});
  }

  nlohmann::ordered_json j;
  j["robot"] = base.config;
  j["peak_force_N"] = base.peak;
  j["resolution_Ns"] = resolution;
  j["max_impulse_Ns"] = max_impulse;
  if (base.alpha) j["alpha"] = *base.alpha;
  if (base.beta) j["beta"] = *base.beta;
  j["overrides"] = base.overrides;
  j["commit"] = source_commit();
  j["executor"] = executor_text;
  j["results"] = nlohmann::ordered_json::array();
  for (const auto& c : cases) {
    nlohmann::ordered_json r;
    r["support"] = c.support;
    r["strategy"] = to_string(c.strategy);
    r["direction_deg"] = c.direction;
    r["max_recovered_Ns"] = c.failed ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(c.max_recovered);
    if (c.reached_max || c.failed) {
      r["min_lost_Ns"] = nullptr;
    } else {
      r["min_lost_Ns"] = c.min_lost;
    }
    r["reached_max"] = c.reached_max;
    r["inconclusive"] = c.inconclusive;
    if (c.failed) {
      r["failed"] = true;
      r["failure"] = c.failure;
    }
    r["trials"] = nlohmann::ordered_json::array();
    for (const auto& t : c.trials) {
      r["trials"].push_back({{"impulse_Ns", t.impulse}, {"recovered", t.recovered}, {"inconclusive", t.inconclusive}});
    }
    j["results"].push_back(r);
  }
  const std::string json_path = out_dir + "/sweep.json";
  std::ofstream(json_path) << j.dump(2) << "\n";
  std::printf("%-7s %-6s %9s %14s\n", "support", "strat.", "direction", "max impulse");
  for (const auto& c : cases) {
    if (c.failed) {
      std::printf("%-7s %-6s %7.0f deg %14s  (%s)\n", c.support.c_str(), to_string(c.strategy), c.direction, "failed", c.failure.c_str());
      continue;
    }
    std::printf("%-7s %-6s %7.0f deg %10.2f N s%s%s\n", c.support.c_str(), to_string(c.strategy), c.direction, c.max_recovered,
                c.reached_max ? "+" : "", c.inconclusive ? "  (a trial stayed inconclusive: may be low)" : "");
  }
  const bool any_failed = std::any_of(cases.begin(), cases.end(), [](const Case& c) { return c.failed; });
  const bool any_inconclusive = std::any_of(cases.begin(), cases.end(), [](const Case& c) { return c.inconclusive; });
  std::printf("table: %s\n", json_path.c_str());
  // The polar plot (matplotlib).
  const fs::path exe = hpr::launch::executable_dir();
  for (const fs::path& script : {exe / ".." / ".." / "tools" / "plots" / "plot_sweep.py", exe / ".." / "share" / "hpr" / "plots" / "plot_sweep.py"}) {
    if (!fs::exists(script)) continue;
    const std::string cmd = fmt::format("/usr/bin/python3 '{}' '{}' '{}/sweep.png'", script.string(), json_path, out_dir);
    if (std::system(cmd.c_str()) == 0) std::printf("plot: %s/sweep.png\n", out_dir.c_str());
    break;
  }
  if (any_failed) {
    std::fprintf(stderr, "push_sweep: some cases did not finish (marked failed in the table and the JSON)\n");
    return 4;
  }
  if (any_inconclusive) {
    std::fprintf(stderr, "push_sweep: some trials stayed inconclusive after %d attempts (marked in the table and the JSON)\n",
                 kTrialAttempts);
    return 3;
  }
  return 0;
}
