// push_sweep: the push envelope. For each direction, support and strategy, the largest impulse the
// robot recovers (push_trial's criteria), found by bracketing and bisection to a resolution
// (largest_recovered: the start, the cap, ×1.5 steps, bisection); in process, each case's trials
// continue one run from just before the push (PrePushCheckpoint); a progress line per trial; a JSON
// table and a polar plot (largest recovered impulse per direction, CAM against ankle).
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>

#include "hpr/common/args.hpp"
#include "hpr/experiments/bisection.hpp"
#include "hpr/experiments/trial.hpp"
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
  --jobs J                trials run at the same time (default 1)
  --out DIR               where sweep.json and sweep.png go (default sweep-<date>)

A trial that ends before it can tell (the stack failed, or a loaded machine held it past its time
limit) is run again, up to 3 times; one that stays inconclusive counts as not recovered, is marked
in the table and the JSON, and the exit status is 3 (0 otherwise, 2 for bad arguments).

The push and the robot (every trial):
)");
  std::fputs(kPushOptionsUsage, out);
}

struct Case {
  std::string support;
  Strategy strategy;
  double direction;
  double max_recovered = 0.0;
  double min_lost = 0.0;  ///< the smallest impulse tried that was not recovered (0: none, reached_max)
  bool reached_max = false;
  bool inconclusive = false;  ///< a trial stayed inconclusive: the largest impulse may be too low
  struct Trial {
    double impulse;
    bool recovered, inconclusive;
  };
  std::vector<Trial> trials;
};

constexpr int kAttempts = 3;

}  // namespace

int main(int argc, char** argv) {
  TrialSpec base;
  base.config = "toro";
  base.stop_when_decided = true;
  std::vector<std::string> supports = {"double"}, strategies = {"cam", "ankle"};
  std::vector<double> angles;
  int directions = 8, jobs = 1;
  double start = 15.0, max_impulse = 80.0, resolution = 0.5;
  std::string out_dir;
  try {
    hpr::ArgReader args(argc, argv);
    while (args.next()) {
      if (args.is("-h", "--help")) {
        usage(stdout);
        return 0;
      } else if (args.is("--supports")) {
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
      } else if (args.is("--jobs")) {
        jobs = std::max(1, args.integer());
      } else if (args.is("--out")) {
        out_dir = args.value();
      } else if (!read_push_option(args, base)) {
        args.unknown();
      }
    }
    if (base.truth_state && !base.in_process) throw std::invalid_argument("--truth-state needs --in-process");
    base.config = find_config(base.config);
    for (const auto& s : strategies) (void)strategy_from_string(s);
    if (angles.empty()) {
      for (int d = 0; d < directions; ++d) angles.push_back(360.0 * d / directions);
    }
    if (!(resolution > 0) || !(start > 0) || !(max_impulse > start) || !(base.peak > 0)) {
      throw std::invalid_argument("need 0 < --start < --max-impulse, --resolution > 0 and --peak > 0");
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "push_sweep: %s\n", e.what());
    usage(stderr);
    return 2;
  }
  if (out_dir.empty()) out_dir = dated_name("sweep");
  fs::create_directories(out_dir);

  std::vector<Case> cases;
  for (const auto& s : supports) {
    for (const auto& st : strategies) {
      for (double d : angles) cases.push_back({s, strategy_from_string(st), d, 0.0, 0.0, false, false, {}});
    }
  }
  std::mutex print_mutex;
  std::atomic<int> trials_done{0};
  const auto t0 = std::chrono::steady_clock::now();
  auto run_case = [&](Case& c) {
    TrialSpec case_spec = base;
    case_spec.support = c.support;
    case_spec.strategy = c.strategy;
    case_spec.direction_deg = c.direction;
    // In process, the case's trials continue one run from just before the push (bit for bit the
    // fresh runs' results).
    const std::unique_ptr<PrePushCheckpoint> checkpoint = PrePushCheckpoint::for_case(case_spec);
    auto trial = [&](double impulse) {
      TrialSpec spec = case_spec;
      spec.impulse = impulse;
      bool ok = false, inconclusive = true;
      std::string why;
      // A run that ended before it could tell (a stack that failed, a machine that held it up past
      // the time limit) says nothing about the robot: it is run again, up to kAttempts times.
      for (int attempt = 1; attempt <= kAttempts && inconclusive; ++attempt) {
        try {
          const TrialResult r = checkpoint ? checkpoint->run(spec) : run_trial(spec);
          ok = r.recovered;
          inconclusive = r.inconclusive;
          why = r.failure;
        } catch (const std::exception& e) {
          why = e.what();
        }
        if (inconclusive && attempt < kAttempts) {
          std::lock_guard<std::mutex> lock(print_mutex);
          std::fprintf(stderr, "  %s %s %.1f deg %.2f N s: inconclusive (%s), running it again\n", c.support.c_str(),
                       to_string(c.strategy), c.direction, impulse, why.c_str());
        }
      }
      if (inconclusive) {
        c.inconclusive = true;
        why = "inconclusive, counted as not recovered: " + why;
      }
      c.trials.push_back({impulse, ok, inconclusive});
      const int n = ++trials_done;
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::lock_guard<std::mutex> lock(print_mutex);
      std::fprintf(stderr, "[%4d, %6.0f s] %-6s %-5s %5.1f deg %6.2f N s: %s\n", n, elapsed, c.support.c_str(),
                   to_string(c.strategy), c.direction, impulse, ok ? "recovered" : ("not recovered (" + why + ")").c_str());
      return ok;
    };
    const ImpulseBracket b = largest_recovered(trial, start, max_impulse, resolution);
    c.reached_max = b.reached_max;
    c.max_recovered = b.max_recovered;
    c.min_lost = b.min_lost;
    std::lock_guard<std::mutex> lock(print_mutex);
    std::fprintf(stderr, "  => %s %s %.0f deg: largest recovered impulse %.2f N s%s\n", c.support.c_str(), to_string(c.strategy),
                 c.direction, c.max_recovered, c.reached_max ? " (the maximum tried)" : "");
  };
  // Cases run `jobs` at a time, each on its own LCM URL, direction by direction (the strategies of
  // one direction side by side: the costly directions are spread over the run, not left to its end).
  std::vector<size_t> order(cases.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return cases[a].direction < cases[b].direction; });
  std::atomic<size_t> next{0};
  std::vector<std::future<void>> workers;
  for (int w = 0; w < jobs; ++w) {
    workers.push_back(std::async(std::launch::async, [&] {
      for (size_t i = next++; i < cases.size(); i = next++) run_case(cases[order[i]]);
    }));
  }
  for (auto& w : workers) w.get();

  nlohmann::ordered_json j;
  j["robot"] = base.config;
  j["peak_force_N"] = base.peak;
  j["resolution_Ns"] = resolution;
  j["max_impulse_Ns"] = max_impulse;
  if (base.alpha) j["alpha"] = *base.alpha;
  if (base.beta) j["beta"] = *base.beta;
  j["overrides"] = base.overrides;
  j["results"] = nlohmann::ordered_json::array();
  for (const auto& c : cases) {
    nlohmann::ordered_json r;
    r["support"] = c.support;
    r["strategy"] = to_string(c.strategy);
    r["direction_deg"] = c.direction;
    r["max_recovered_Ns"] = c.max_recovered;
    if (c.reached_max) {
      r["min_lost_Ns"] = nullptr;
    } else {
      r["min_lost_Ns"] = c.min_lost;
    }
    r["reached_max"] = c.reached_max;
    r["inconclusive"] = c.inconclusive;
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
    std::printf("%-7s %-6s %7.0f deg %10.2f N s%s%s\n", c.support.c_str(), to_string(c.strategy), c.direction, c.max_recovered,
                c.reached_max ? "+" : "", c.inconclusive ? "  (a trial stayed inconclusive: may be low)" : "");
  }
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
  if (any_inconclusive) {
    std::fprintf(stderr, "push_sweep: some trials stayed inconclusive after %d attempts (marked in the table and the JSON)\n", kAttempts);
    return 3;
  }
  return 0;
}
