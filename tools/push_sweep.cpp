// push_sweep: the push envelope. For each direction, support and strategy, the largest impulse the
// robot recovers (push_trial's criteria), found by bracketing and bisection to a resolution
// (largest_recovered: the start, the cap, ×1.5 steps, bisection); in process, each case's trials
// continue one run from just before the push (PrePushCheckpoint); the cases run on this machine
// or as a Slurm job array (--executor, executor.hpp); a progress line per trial; a JSON table and
// a polar plot (largest recovered impulse per direction, CAM against ankle). --dominance: the
// default controller against each single strategy standing, at three peaks (dominance.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>

#include "hpr/common/args.hpp"
#include "hpr/experiments/dominance.hpp"
#include "hpr/experiments/executor.hpp"
#include "hpr/experiments/version.hpp"
#include "hpr/launch/process_group.hpp"

namespace {

using namespace hpr::experiments;
namespace fs = std::filesystem;

void usage(std::FILE* out) {
  std::fprintf(out, R"(usage: push_sweep [options]

  --supports LIST         comma-separated: double,left,right (default double)
  --strategies LIST       comma-separated: cam,ankle (as configured: stepping when the configuration
                          steps), cam-standing,ankle-standing (stepping off) (default cam,ankle)
  --peaks LIST            comma-separated peak forces [N], one envelope each (default: --peak)
  --dominance             the table of the default against each single strategy: strategies
                          cam,cam-standing,ankle-standing, peaks 65,130,260 N, 8 directions in double
                          support and sideways (90, 270 deg) on either foot; --max-impulse 120 unless
                          given; checks and prints the table (dominance.md beside sweep.json)
  --engines LIST          every case in each physics engine: bullet,mujoco (default: the
                          configuration's); with two, the limits side by side with their ratio
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
  std::string engine;            ///< "" (the configuration's) or an engine of --engines
  std::string support;
  std::string strategy = "cam";  ///< a strategy name of --strategies (Variant)
  double peak = 65.0;            ///< [N]
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

/// What the command line asks for.
struct SweepOptions {
  TrialSpec base;
  std::vector<std::string> supports = {"double"}, strategies = {"cam", "ankle"};
  std::vector<std::string> engines;  ///< --engines: every case in each (empty: the configuration's engine)
  std::vector<double> angles, peaks;
  int directions = 8;
  bool dominance = false;
  ExecutorOptions executor;
  double start = 15.0, max_impulse = 80.0, resolution = 0.5;
  bool max_impulse_given = false;
  std::string out_dir;
};

/// The options, or the exit status when the command line is refused or asked for help.
std::optional<int> read_options(int argc, char** argv, SweepOptions& o) {
  o.base.config = "toro";
  o.base.stop_when_decided = true;
  const auto option = [&](hpr::ArgReader& args) {
    if (args.is("--supports")) {
      o.supports = args.list();
    } else if (args.is("--strategies")) {
      o.strategies = args.list();
    } else if (args.is("--directions")) {
      o.directions = args.integer();
      if (o.directions < 1) throw hpr::UsageError("--directions: at least 1");
    } else if (args.is("--peaks")) {
      for (const auto& a : args.list()) o.peaks.push_back(hpr::parse_number(a, "--peaks"));
    } else if (args.is("--dominance")) {
      o.dominance = true;
    } else if (args.is("--engines")) {
      o.engines = args.list();
      for (const auto& e : o.engines) {
        if (e != "bullet" && e != "mujoco") throw hpr::UsageError("--engines: '" + e + "': expected bullet or mujoco");
      }
    } else if (args.is("--angles")) {
      for (const auto& a : args.list()) o.angles.push_back(hpr::parse_number(a, "--angles"));
    } else if (args.is("--start")) {
      o.start = args.number();
    } else if (args.is("--max-impulse")) {
      o.max_impulse = args.number();
      o.max_impulse_given = true;
    } else if (args.is("--resolution")) {
      o.resolution = args.number();
    } else if (args.is("--out")) {
      o.out_dir = args.value();
    } else if (!o.executor.read(args) && !read_push_option(args, o.base)) {
      args.unknown();
    }
  };
  const auto check = [&] {
    o.executor.validate();
    if (o.executor.resume && o.out_dir.empty()) throw hpr::UsageError("--resume needs --out DIR");
    if (o.base.truth_state && !o.base.in_process) throw std::invalid_argument("--truth-state needs --in-process");
    o.base.config = find_config(o.base.config);
    if (o.dominance) {
      o.strategies = {"cam", "cam-standing", "ankle-standing"};
      if (o.peaks.empty()) o.peaks = {65.0, 130.0, 260.0};
      if (!o.max_impulse_given) o.max_impulse = 120.0;
    }
    if (o.peaks.empty()) o.peaks = {o.base.peak};
    for (const auto& st : o.strategies) (void)variant_from_string(st);
    if (o.angles.empty()) {
      for (int d = 0; d < o.directions; ++d) o.angles.push_back(360.0 * d / o.directions);
    }
    const bool peaks_positive = std::all_of(o.peaks.begin(), o.peaks.end(), [](double p) { return p > 0; });
    if (!(o.resolution > 0) || !(o.start > 0) || !(o.max_impulse > o.start) || !peaks_positive) {
      throw std::invalid_argument("need 0 < --start < --max-impulse, --resolution > 0 and every peak > 0");
    }
  };
  return hpr::read_command_line(argc, argv, "push_sweep", usage, option, check);
}

/// Every (peak, support, strategy, direction), in the table's order. With --dominance the supports
/// are double (every direction) and either foot pushed sideways.
std::vector<Case> cases_of(const SweepOptions& o) {
  std::vector<std::pair<std::string, double>> cells;
  if (o.dominance) {
    for (double d : o.angles) cells.emplace_back("double", d);
    for (const char* foot : {"left", "right"}) {
      for (double d : {90.0, 270.0}) cells.emplace_back(foot, d);
    }
  } else {
    for (const auto& s : o.supports) {
      for (double d : o.angles) cells.emplace_back(s, d);
    }
  }
  std::vector<Case> cases;
  const std::vector<std::string> engines = o.engines.empty() ? std::vector<std::string>{""} : o.engines;
  for (double peak : o.peaks) {
    for (const auto& [support, direction] : cells) {
      for (const auto& st : o.strategies) {
        for (const auto& engine : engines) {
          Case c;
          c.engine = engine;
          c.support = support;
          c.strategy = st;
          c.peak = peak;
          c.direction = direction;
          cases.push_back(c);
        }
      }
    }
  }
  return cases;
}

/// The engine a search's overrides ask for, with a space after it ("" when they ask for none).
std::string engine_tag(const SearchSpec& s) {
  std::string engine;
  for (const auto& o : s.base.overrides) {
    if (o.rfind("sim.engine=", 0) == 0) engine = o.substr(11) + " ";
  }
  return engine;
}

/// The progress lines: one per trial, one per finished search (k of `searches`).
ExecutorEvents progress_lines(int& trials_done, int& searches_done, size_t searches, std::chrono::steady_clock::time_point t0) {
  ExecutorEvents events;
  events.trial = [&trials_done, t0](const SearchSpec& s, const TrialOutcome& t, bool stored) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "[%4d, %6.0f s] %s%-6s %-14s %3.0f N %5.1f deg %6.2f N s: %s%s\n", ++trials_done, elapsed,
                 engine_tag(s).c_str(), s.base.support.c_str(), variant_name(s.base).c_str(), s.base.peak, s.base.direction_deg, t.impulse,
                 t.result.recovered ? "recovered" : ("not recovered (" + t.result.failure + ")").c_str(), stored ? " [stored]" : "");
  };
  events.search = [&searches_done, searches](const SearchSpec& s, const SearchResult& r) {
    ++searches_done;
    if (r.failed) {
      std::fprintf(stderr, "  => [%d/%zu] %s: FAILED, %s\n", searches_done, searches, s.label().c_str(), r.failure.c_str());
      return;
    }
    std::fprintf(stderr, "  => [%d/%zu] %s%s %s %.0f N %.0f deg: largest recovered impulse %.2f N s%s\n", searches_done, searches,
                 engine_tag(s).c_str(), s.base.support.c_str(),
                 variant_name(s.base).c_str(), s.base.peak, s.base.direction_deg, r.bracket.max_recovered,
                 r.bracket.reached_max ? " (the maximum tried)" : "");
  };
  events.note = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  return events;
}

/// sweep.json: the push, the robot, and every case with its trials.
nlohmann::ordered_json sweep_json(const SweepOptions& o, const std::vector<Case>& cases, const std::string& executor_text) {
  using ojson = nlohmann::ordered_json;
  ojson j;
  j["robot"] = o.base.config;
  j["peak_force_N"] = o.peaks.front();
  j["peaks_N"] = o.peaks;
  j["resolution_Ns"] = o.resolution;
  j["max_impulse_Ns"] = o.max_impulse;
  if (o.base.alpha) j["alpha"] = *o.base.alpha;
  if (o.base.beta) j["beta"] = *o.base.beta;
  j["overrides"] = o.base.overrides;
  j["commit"] = source_commit();
  j["executor"] = executor_text;
  j["results"] = ojson::array();
  for (const auto& c : cases) {
    ojson r;
    if (!c.engine.empty()) r["engine"] = c.engine;
    r["support"] = c.support;
    r["strategy"] = c.strategy;
    r["peak_force_N"] = c.peak;
    r["direction_deg"] = c.direction;
    r["max_recovered_Ns"] = c.failed ? ojson(nullptr) : ojson(c.max_recovered);
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
    r["trials"] = ojson::array();
    for (const auto& t : c.trials) {
      r["trials"].push_back({{"impulse_Ns", t.impulse}, {"recovered", t.recovered}, {"inconclusive", t.inconclusive}});
    }
    j["results"].push_back(r);
  }
  return j;
}

/// The table on stdout.
void print_table(const std::vector<Case>& cases) {
  const bool engines = !cases.empty() && !cases.front().engine.empty();
  std::printf("%s%-7s %-14s %6s %9s %14s\n", engines ? "engine  " : "", "support", "strategy", "peak", "direction", "max impulse");
  for (const auto& c : cases) {
    if (engines) std::printf("%-7s ", c.engine.c_str());
    if (c.failed) {
      std::printf("%-7s %-14s %4.0f N %5.0f deg %14s  (%s)\n", c.support.c_str(), c.strategy.c_str(), c.peak, c.direction, "failed",
                  c.failure.c_str());
      continue;
    }
    std::printf("%-7s %-14s %4.0f N %5.0f deg %10.2f N s%s%s\n", c.support.c_str(), c.strategy.c_str(), c.peak, c.direction, c.max_recovered,
                c.reached_max ? "+" : "", c.inconclusive ? "  (a trial stayed inconclusive: may be low)" : "");
  }
}

/// With two engines: each cell's limits side by side, the second engine's against the first's, a
/// difference above 15 % marked.
void print_engine_comparison(const SweepOptions& o, const std::vector<Case>& cases) {
  if (o.engines.size() != 2) return;
  std::printf("\n%-7s %-14s %6s %9s %10s %10s %7s\n", "support", "strategy", "peak", "direction", o.engines[0].c_str(), o.engines[1].c_str(), "ratio");
  for (size_t i = 0; i + 1 < cases.size(); i += 2) {
    const Case& a = cases[i];
    const Case& b = cases[i + 1];
    if (a.failed || b.failed) continue;
    const double ratio = a.max_recovered > 0 ? b.max_recovered / a.max_recovered : 0.0;
    std::printf("%-7s %-14s %4.0f N %5.0f deg %8.2f%s %8.2f%s %7.3f%s\n", a.support.c_str(), a.strategy.c_str(), a.peak, a.direction,
                a.max_recovered, a.reached_max ? "+" : " ", b.max_recovered, b.reached_max ? "+" : " ", ratio,
                std::abs(ratio - 1.0) > 0.15 ? "  (differ by more than 15 %)" : "");
  }
}

/// The polar plot (matplotlib), from the build tree's or the installed script.
void plot(const std::string& json_path, const std::string& out_dir) {
  const fs::path exe = hpr::launch::executable_dir();
  for (const fs::path& script : {exe / ".." / ".." / "tools" / "plots" / "plot_sweep.py", exe / ".." / "share" / "hpr" / "plots" / "plot_sweep.py"}) {
    if (!fs::exists(script)) continue;
    const std::string cmd = fmt::format("/usr/bin/python3 '{}' '{}' '{}/sweep.png'", script.string(), json_path, out_dir);
    if (std::system(cmd.c_str()) == 0) std::printf("plot: %s/sweep.png\n", out_dir.c_str());
    break;
  }
}

}  // namespace

int main(int argc, char** argv) {
  SweepOptions o;
  if (const auto status = read_options(argc, argv, o)) return *status;
  if (o.out_dir.empty()) o.out_dir = dated_name("sweep");
  fs::create_directories(o.out_dir);

  std::vector<Case> cases = cases_of(o);
  // The cases direction by direction (the strategies of one direction side by side: the costly
  // directions are spread over the run, not left to its end).
  std::vector<size_t> order(cases.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return cases[a].direction < cases[b].direction; });
  std::vector<SearchSpec> searches;
  for (const size_t i : order) {
    SearchSpec search;
    search.base = o.base;
    search.base.support = cases[i].support;
    search.base.peak = cases[i].peak;
    search.base.direction_deg = cases[i].direction;
    apply(variant_from_string(cases[i].strategy), search.base);
    if (!cases[i].engine.empty()) search.base.overrides.push_back("sim.engine=" + cases[i].engine);
    search.start = o.start;
    search.max_impulse = o.max_impulse;
    search.resolution = o.resolution;
    searches.push_back(search);
  }

  int trials_done = 0;
  int searches_done = 0;
  const ExecutorEvents events = progress_lines(trials_done, searches_done, searches.size(), std::chrono::steady_clock::now());
  std::vector<SearchResult> results;
  std::string executor_text;
  try {
    const auto run = make_executor(o.executor, o.out_dir, events);
    executor_text = run->describe();
    const std::string trials_dir =
        o.executor.kind == "slurm" ? (o.executor.shared_dir ? *o.executor.shared_dir : o.out_dir + "/slurm") : o.out_dir + "/trials";
    std::fprintf(stderr, "push_sweep: %zu cases, %s; trials in %s\n", cases.size(), executor_text.c_str(), trials_dir.c_str());
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

  const std::string json_path = o.out_dir + "/sweep.json";
  std::ofstream(json_path) << sweep_json(o, cases, executor_text).dump(2) << "\n";
  print_table(cases);
  print_engine_comparison(o, cases);
  std::printf("table: %s\n", json_path.c_str());
  plot(json_path, o.out_dir);
  if (o.dominance) {
    std::vector<DominanceCell> cells;
    for (const auto& c : cases) {
      cells.push_back({c.support, c.strategy, c.peak, c.direction, c.failed ? std::nullopt : std::optional(c.max_recovered), c.reached_max});
    }
    const std::string md = dominance_table(cells, o.base.config, o.max_impulse, o.resolution);
    std::ofstream(o.out_dir + "/dominance.md") << md;
    std::printf("\n%s\ndominance table: %s/dominance.md\n", md.c_str(), o.out_dir.c_str());
  }
  if (std::any_of(cases.begin(), cases.end(), [](const Case& c) { return c.failed; })) {
    std::fprintf(stderr, "push_sweep: some cases did not finish (marked failed in the table and the JSON)\n");
    return 4;
  }
  if (std::any_of(cases.begin(), cases.end(), [](const Case& c) { return c.inconclusive; })) {
    std::fprintf(stderr, "push_sweep: some trials stayed inconclusive after %d attempts (marked in the table and the JSON)\n",
                 kTrialAttempts);
    return 3;
  }
  return 0;
}
