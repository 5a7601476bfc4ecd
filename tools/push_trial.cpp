// push_trial: one push-recovery experiment with every process of the stack in lockstep against
// sim_bullet (estimator in the loop). Prints one JSON object on stdout and progress on stderr.
//
// Exit status: 0 recovered, 1 not recovered, 2 bad arguments or configuration, 3 inconclusive (the run
// ended before 5 s after the push with nothing decided: --after below 5, or the stack stopped), 4 the
// run failed.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "hpr/common/args.hpp"
#include "hpr/common/config.hpp"
#include "hpr/experiments/trial.hpp"
#include "hpr/launch/process_group.hpp"

#include <fmt/format.h>

namespace {

void usage(std::FILE* out) {
  std::fprintf(out, R"(usage: push_trial [options]

One push experiment: sim_bullet, estimator, wbc and (strategy cam) reference_gen and motion_opt in
lockstep on a private LCM URL (or, with --in-process, their libraries in one thread). Prints a JSON object: recovered, fallen, applied impulse, maximum foot
tilt, maximum sole slip, peak CAM per axis, minimum CoP margin, time to return to the posture.

  --support S           double | left | right (default double)
  --strategy S          cam | ankle (ankle: the wbc holds the posture, no CAM reference), stepping as
                        configured; cam-standing | ankle-standing: stepping off (default cam)
  --direction DEG       push direction: 0 = pushed forward from behind, 90 = towards +y, 180 = from the front
  --impulse NS          impulse of the half-sine push [N s] (default 18; 0 with no --duration: no push,
                        a standing trial judged alike)
  --stand S             a standing trial of S seconds (at least 5) from when the push would have come:
                        --impulse 0 --after S
  --duration S          push duration [s] (default: from impulse and peak, I = 2 F T / pi)
  --log FILE            record the LCM log of the run
  --work-dir DIR        keep the processes' output there
  --lcm-url URL         run the processes on this LCM URL, so that lcm-spy or the viewer can watch the
                        trial (default: a URL of its own that no other run meets)
  --json FILE           also write the JSON object to FILE
  --video FILE          render the run to an MP4 with the 3D viewer (headless Chromium, ffmpeg)
  --video-label TEXT    caption written on the video (default: the strategy and the push)
  --quiet               no progress on stderr
)");
  std::fputs(hpr::experiments::kPushOptionsUsage, out);
  std::fputs("\nExit status: 0 recovered, 1 not recovered, 2 bad arguments or configuration, 3 inconclusive (the\n"
             "run ended before 5 s after the push with nothing decided: --after below 5, or the stack stopped\n"
             "early; \"inconclusive\": true in the JSON), 4 the run failed.\n",
             out);
}

/// tools/render-video next to this build (build/bin/../../tools) or installed as hpr-render-video.
std::string find_render_video() {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe = hpr::launch::executable_dir();
  for (const fs::path& p : {exe / ".." / ".." / "tools" / "render-video", exe / "hpr-render-video"}) {
    if (fs::exists(p, ec)) return fs::weakly_canonical(p, ec).string();
  }
  throw std::runtime_error("--video: tools/render-video not found next to " + exe.string());
}

/// What the command line asks for.
struct TrialOptions {
  hpr::experiments::TrialSpec spec;
  std::string json_file, video_file, video_label;
  bool quiet = false;
};

/// The options, or the exit status when the command line is refused or asked for help.
std::optional<int> read_options(int argc, char** argv, TrialOptions& o) {
  using namespace hpr::experiments;
  TrialSpec& spec = o.spec;
  spec.config = "toro";
  Variant variant;
  return hpr::read_command_line(
      argc, argv, "push_trial", usage,
      [&](hpr::ArgReader& args) {
        if (args.is("--support")) {
          spec.support = args.value();
        } else if (args.is("--strategy")) {
          variant = variant_from_string(args.value());
        } else if (args.is("--direction")) {
          spec.direction_deg = args.number();
        } else if (args.is("--impulse")) {
          spec.impulse = args.number();
        } else if (args.is("--stand")) {
          spec.impulse = 0.0;
          spec.duration = 0.0;
          spec.after = args.number();
          if (!(spec.after >= TrialEvaluator::kSettleTime)) {
            throw std::invalid_argument(
                fmt::format("--stand {}: a standing trial's verdict needs at least {:.0f} s", spec.after, TrialEvaluator::kSettleTime));
          }
        } else if (args.is("--duration")) {
          spec.duration = args.number();
        } else if (args.is("--log")) {
          spec.log_file = args.value();
        } else if (args.is("--lcm-url")) {
          spec.lcm_url = args.value();
        } else if (args.is("--work-dir")) {
          spec.work_dir = args.value();
        } else if (args.is("--json")) {
          o.json_file = args.value();
        } else if (args.is("--video")) {
          o.video_file = args.value();
        } else if (args.is("--video-label")) {
          o.video_label = args.value();
        } else if (args.is("--quiet")) {
          o.quiet = true;
        } else if (!read_push_option(args, spec)) {
          args.unknown();
        }
      },
      [&] {
        if (spec.support != "double" && spec.support != "left" && spec.support != "right") {
          throw std::invalid_argument("--support '" + spec.support + "': expected double, left or right");
        }
        if (!(spec.peak > 0) || spec.impulse < 0 || spec.duration < 0) {
          throw std::invalid_argument("the push needs --peak > 0 and a positive --impulse or --duration (--impulse 0: no push)");
        }
        spec.config = find_config(spec.config);
        apply(variant, spec);  // after every --set and --overlay: "-standing" has the last word
        if (spec.truth_state && !spec.in_process) throw std::invalid_argument("--truth-state needs --in-process");
        if (!spec.lcm_url.empty() && spec.in_process) throw std::invalid_argument("--lcm-url: an --in-process trial has no LCM");
        if (spec.in_process && (!spec.log_file.empty() || !o.video_file.empty())) {
          throw std::invalid_argument("--in-process writes no log: --log and --video need the processes");
        }
        if (!o.video_file.empty() && spec.log_file.empty()) {
          spec.log_file = (std::filesystem::path(o.video_file).replace_extension(".lcm")).string();
        }
      });
}

/// The trial's video (tools/render-video on its log); 0, else render-video's exit status.
int render_video(const TrialOptions& o) {
  using hpr::experiments::Strategy;
  const hpr::experiments::TrialSpec& spec = o.spec;
  std::string label = o.video_label;
  const char* strategy = spec.strategy == Strategy::kCam ? "CAM strategy" : "ankle strategy alone";
  if (label.empty() && spec.standing()) {
    label = fmt::format("{}, standing", strategy);
  } else if (label.empty()) {
    label = fmt::format("{}, {:.3g} N s at {:.0f} deg", strategy, spec.impulse, spec.direction_deg);
  }
  return hpr::launch::run_to_completion(
      {find_render_video(), spec.log_file, o.video_file, "--robot", spec.config, "--label", label});
}

}  // namespace

int main(int argc, char** argv) {
  using namespace hpr::experiments;
  TrialOptions o;
  if (const auto status = read_options(argc, argv, o)) return *status;
  const TrialSpec& spec = o.spec;
  try {
    if (!o.quiet && spec.standing()) {
      std::fprintf(stderr, "push_trial: %s, %s support, %s strategy, standing %.3g s without a push\n", spec.config.c_str(),
                   spec.support.c_str(), to_string(spec.strategy), spec.after);
    } else if (!o.quiet) {
      std::fprintf(stderr, "push_trial: %s, %s support, %s strategy, %.4g N s at %.0f deg (%.0f N peak, %.3f s)\n",
                   spec.config.c_str(), spec.support.c_str(), to_string(spec.strategy), spec.impulse, spec.direction_deg,
                   spec.peak, spec.push_duration());
    }
    const TrialResult r = run_trial(spec, o.quiet ? std::function<void(const std::string&)>() : [](const std::string& line) {
      std::fprintf(stderr, "%s\n", line.c_str());
    });
    const std::string json = r.to_json(spec);
    std::printf("%s\n", json.c_str());
    if (!o.json_file.empty()) {
      std::FILE* f = std::fopen(o.json_file.c_str(), "w");
      if (f != nullptr) {
        std::fprintf(f, "%s\n", json.c_str());
        std::fclose(f);
      }
    }
    if (!o.quiet) {
      std::fprintf(stderr, "push_trial: %s%s%s (minimum CoP margin %.1f mm; %.1f s simulated in %.1f s)\n\n%s", r.outcome.c_str(),
                   r.failure.empty() ? "" : ": ", r.failure.c_str(), 1e3 * r.min_cop_margin, r.sim_time, r.wall_time,
                   kOutcomeLegend);
    }
    if (!o.video_file.empty()) {
      if (const int rc = render_video(o); rc != 0) {
        std::fprintf(stderr, "push_trial: rendering %s failed (tools/render-video exited with %d)\n", o.video_file.c_str(), rc);
        return 4;
      }
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
