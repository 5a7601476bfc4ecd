// push_trial: one push-recovery experiment with every process of the stack in lockstep against
// sim_bullet (estimator in the loop). Prints one JSON object on stdout and progress on stderr.
//
// Exit status: 0 recovered, 1 not recovered, 2 bad arguments or configuration, 3 inconclusive (the run
// ended before 5 s after the push with nothing decided: --after below 5, or the stack stopped), 4 the
// run failed.
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>

#include "hpr/common/args.hpp"
#include "hpr/common/config.hpp"
#include "hpr/experiments/trial.hpp"

namespace {

void usage(std::FILE* out) {
  std::fprintf(out, R"(usage: push_trial [options]

One push experiment: sim_bullet, estimator, wbc and (strategy cam) reference_gen and motion_opt in
lockstep on a private LCM URL. Prints a JSON object: recovered, fallen, applied impulse, maximum foot
tilt, maximum sole slip, peak CAM per axis, minimum CoP margin, time to return to the posture.

  --support S           double | left | right (default double)
  --strategy S          cam | ankle (ankle: the wbc holds the posture, no CAM reference) (default cam)
  --direction DEG       push direction: 0 = pushed forward from behind, 90 = towards +y, 180 = from the front
  --impulse NS          impulse of the half-sine push [N s] (default 18)
  --duration S          push duration [s] (default: from impulse and peak, I = 2 F T / pi)
  --log FILE            record the LCM log of the run
  --work-dir DIR        keep the processes' output there
  --json FILE           also write the JSON object to FILE
  --quiet               no progress on stderr
)");
  std::fputs(hpr::experiments::kPushOptionsUsage, out);
  std::fputs("\nExit status: 0 recovered, 1 not recovered, 2 bad arguments or configuration, 3 inconclusive (the\n"
             "run ended before 5 s after the push with nothing decided: --after below 5, or the stack stopped\n"
             "early; \"inconclusive\": true in the JSON), 4 the run failed.\n",
             out);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace hpr::experiments;
  TrialSpec spec;
  spec.config = "toro";
  std::string json_file;
  bool quiet = false;
  try {
    hpr::ArgReader args(argc, argv);
    while (args.next()) {
      if (args.is("-h", "--help")) {
        usage(stdout);
        return 0;
      } else if (args.is("--support")) {
        spec.support = args.value();
      } else if (args.is("--strategy")) {
        spec.strategy = strategy_from_string(args.value());
      } else if (args.is("--direction")) {
        spec.direction_deg = args.number();
      } else if (args.is("--impulse")) {
        spec.impulse = args.number();
      } else if (args.is("--duration")) {
        spec.duration = args.number();
      } else if (args.is("--log")) {
        spec.log_file = args.value();
      } else if (args.is("--work-dir")) {
        spec.work_dir = args.value();
      } else if (args.is("--json")) {
        json_file = args.value();
      } else if (args.is("--quiet")) {
        quiet = true;
      } else if (!read_push_option(args, spec)) {
        args.unknown();
      }
    }
    if (spec.support != "double" && spec.support != "left" && spec.support != "right") {
      throw std::invalid_argument("--support '" + spec.support + "': expected double, left or right");
    }
    if (!(spec.peak > 0) || spec.impulse < 0 || spec.duration < 0 || (spec.impulse == 0 && spec.duration == 0)) {
      throw std::invalid_argument("the push needs --peak > 0 and a positive --impulse or --duration");
    }
    spec.config = find_config(spec.config);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "push_trial: %s\n", e.what());
    usage(stderr);
    return 2;
  }
  try {
    if (!quiet) {
      std::fprintf(stderr, "push_trial: %s, %s support, %s strategy, %.4g N s at %.0f deg (%.0f N peak, %.3f s)\n",
                   spec.config.c_str(), spec.support.c_str(), to_string(spec.strategy), spec.impulse, spec.direction_deg,
                   spec.peak, spec.push_duration());
    }
    const TrialResult r = run_trial(spec, quiet ? std::function<void(const std::string&)>() : [](const std::string& line) {
      std::fprintf(stderr, "%s\n", line.c_str());
    });
    const std::string json = r.to_json(spec);
    std::printf("%s\n", json.c_str());
    if (!json_file.empty()) {
      std::FILE* f = std::fopen(json_file.c_str(), "w");
      if (f != nullptr) {
        std::fprintf(f, "%s\n", json.c_str());
        std::fclose(f);
      }
    }
    if (!quiet) {
      std::fprintf(stderr, "push_trial: %s%s (%.1f s simulated in %.1f s)\n",
                   r.recovered ? "recovered" : (r.inconclusive ? "INCONCLUSIVE: " : "NOT recovered: "), r.failure.c_str(), r.sim_time,
                   r.wall_time);
    }
    return r.recovered ? 0 : (r.inconclusive ? 3 : 1);
  } catch (const hpr::ConfigError& e) {
    std::fprintf(stderr, "push_trial: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "push_trial: %s\n", e.what());
    return 4;
  }
}
