// hpr_robot: onboarding a robot description.
//
//   hpr_robot check URDF [--mesh-path DIR]... [--base LINK]
//   hpr_robot init URDF --out FILE.yaml [--name N] [--hold J]... [--keep J]... [--verify]
//
// check loads the URDF as the stack does (with the loader's repairs reported), builds the model and
// prints its tree, joint counts, mass, centre of mass, meshes and candidate feet with their soles.
// init writes a complete configuration (config/templates/robot.yaml filled in) and, with --verify,
// stands the robot in the simulator and pushes it from behind and from the front.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <unistd.h>

#include "hpr/common/args.hpp"
#include "hpr/experiments/executor.hpp"
#include "hpr/experiments/trial.hpp"
#include "hpr/launch/process_group.hpp"
#include "hpr/model/model.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/onboard/robot_check.hpp"
#include "hpr/onboard/robot_draft.hpp"

namespace {

constexpr const char* kUsage = R"(usage: hpr_robot check URDF [options]
       hpr_robot init URDF --out FILE.yaml [options]

check:

Reads a robot description as the stack does and reports what a configuration needs: the kinematic
tree, joints by type, total mass and centre of mass, every repair the loader made (massless
<inertial>, regularised inertias, locked mimic joints), the meshes, and the candidate feet with the
sole rectangle their collision geometry gives.

  --mesh-path DIR   a folder where package:// and relative mesh paths are looked up (repeatable;
                    HPR_MESH_PATH and ROS_PACKAGE_PATH are used too)
  --base LINK       floating base (default: the URDF root, or the child of its floating joint)

init: writes a complete, commented configuration for the robot: the feet (the lowest links at the end
of the leg chains) with their soles from the collision geometry (the largest rectangle along the
sole's long axis inside its lowest face, sole_rpy when that axis is yawed in the link), the IMU (a
link named imu, imu_link, *_imu* anywhere on the tree, rigidly on the base first, else the base),
held joints (hands, fingers, grippers, head: names containing hand, finger,
thumb, index, middle, ring, pinky, little, gripper, head, neck, eye), a standing posture by inverse
kinematics (hips at a fraction of the straight leg above the soles, soles flat, CoM over their
middle, shoulders 0.15 rad out, elbows bent 0.4 rad), segments, the motion optimiser's adjusted
coordinates (base rotation, torso, first four joints of each arm) and gains scaled to the robot's
mass and inertia; the rest is the stack's defaults (config/templates/robot.yaml). The file is
loaded as the processes load it before it takes its place: a failed init writes nothing.

  --out FILE            the configuration to write (required; an existing file is not overwritten
                        without --force)
  --name NAME           robot name (default: the URDF's)
  --leg-height F        hips at F times the straight leg's length above the soles (default 0.90)
  --hold JOINT          hold this joint too (repeatable)
  --keep JOINT          never hold this joint (repeatable)
  --mesh-path DIR       as for check, and written into FILE as robot.mesh_search_paths (relative
                        to FILE, so that it loads wherever the two move together)
  --base LINK           as for check
  --force               overwrite FILE
  --verify              then a standing trial of 10 s in the simulator (every process loads FILE), and
                        the largest push from behind and from the front that the default controller
                        and the ankle strategy alone recover (a bisection each, in process; pushes
                        of max(20, 2 m) N peak), with the legend of the outcomes
  --tune                then push_tune for the robot (alpha, beta, Q_l, Q_p, K_p; pushes scaled as
                        --verify's, from behind and from the front) into FILE-tune/, its best values
                        written as the overlay FILE.tuned.yaml beside FILE (--overlay for the tools)
  --tune-evaluations N  push_tune's evaluations (default push_tune's, 60)
  --jobs N              --verify's searches and --tune's directions at the same time (default: the
                        number of cores)

Exit status: 0 the description loads (init: and with --verify the robot stands), 1 it does not (the
error names the file, element and value), 2 bad arguments.
)";

std::string read_file(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

/// The pushes --verify and --tune try on a new robot, scaled to its ankle strategy's bound m ω d
/// (d the sole's half length): a start of half the bound, up to 4 times it, to 2 % of it, with a peak
/// force of max(20 N, 2 m).
struct PushScale {
  double omega = 0.0, d = 0.0, bound = 0.0;  ///< [1/s], [m], [N s]
  double peak = 0.0;                         ///< [N]
  double start = 0.0, max_impulse = 0.0, resolution = 0.0;  ///< [N s]
};

PushScale push_scale(const hpr::onboard::RobotDraft& draft) {
  PushScale p;
  p.omega = std::sqrt(9.81 / draft.com_height);
  p.d = 0.5 * draft.feet[0].sole.length;
  p.bound = draft.mass * p.omega * p.d;
  p.peak = std::max(20.0, 2.0 * draft.mass);
  p.start = std::round(5.0 * p.bound) / 10.0;
  p.max_impulse = std::round(40.0 * p.bound) / 10.0;
  p.resolution = std::max(0.25, std::round(20.0 * p.bound) / 1000.0);
  return p;
}

// A standing trial of 10 s through the processes (each loads the file), then the largest push each
// of the default controller and the ankle strategy alone recovers from behind and from the front
// (in process, a bisection per case, `jobs` at a time).
int verify(const std::string& config, const hpr::onboard::RobotDraft& draft, int jobs) {
  using hpr::experiments::SearchSpec;
  using hpr::experiments::Strategy;
  hpr::experiments::TrialSpec stand;
  stand.config = config;
  stand.impulse = 0.0;
  stand.duration = 0.0;
  stand.after = 10.0;
  std::printf("verify: a standing trial of 10 s ...\n");
  std::fflush(stdout);
  const auto st = hpr::experiments::run_trial(stand);
  if (!st.recovered) {
    std::printf("verify: the robot does not stand: %s (%s)\n\n%s", st.outcome.c_str(), st.failure.c_str(),
                hpr::experiments::kOutcomeLegend);
    return 1;
  }
  std::printf("verify: stood 10 s (CoM within %.1f mm, soles within %.2f deg and %.1f mm)\n", 1e3 * st.max_com_deviation,
              st.max_tilt_deg, 1e3 * st.max_slip);
  const PushScale scale = push_scale(draft);
  std::printf("\n  ankle strategy's bound m w d = %.1f kg x %.2f 1/s x %.3f m = %.1f N s; pushes of %.0f N peak\n", draft.mass,
              scale.omega, scale.d, scale.bound, scale.peak);
  std::vector<SearchSpec> searches;
  for (const double dir : {0.0, 180.0}) {
    for (const Strategy s : {Strategy::kCam, Strategy::kAnkle}) {
      SearchSpec sp;
      sp.base.config = config;
      sp.base.strategy = s;
      sp.base.direction_deg = dir;
      sp.base.peak = scale.peak;
      sp.base.in_process = true;
      sp.base.stop_when_decided = true;
      sp.start = scale.start;
      sp.max_impulse = scale.max_impulse;
      sp.resolution = scale.resolution;
      searches.push_back(sp);
    }
  }
  std::printf("  largest recovered push, bisection to %.2f N s (%zu searches, %d at a time):\n", searches.front().resolution,
              searches.size(), jobs);
  std::fflush(stdout);
  namespace fs = std::filesystem;
  const fs::path store = fs::temp_directory_path() / fmt::format("hpr-verify-{}", ::getpid());
  hpr::experiments::ExecutorEvents events;
  events.trial = [](const SearchSpec& sp, const hpr::experiments::TrialOutcome& t, bool) {
    std::printf("    %-16s %6.2f N s: %s\n", sp.label().c_str(), t.impulse, t.result.outcome.c_str());
    std::fflush(stdout);
  };
  const auto results = hpr::experiments::make_local_executor(jobs, store.string(), false, events)->run(searches);
  fs::remove_all(store);
  std::printf("\n  %-8s %-22s %12s  %s\n", "from", "controller", "largest N s", "smallest lost N s");
  double largest[2][2] = {};
  for (size_t i = 0; i < results.size(); ++i) {
    const auto& sp = searches[i];
    const auto& r = results[i];
    const int di = sp.base.direction_deg == 0.0 ? 0 : 1, si = sp.base.strategy == Strategy::kCam ? 0 : 1;
    largest[di][si] = r.bracket.max_recovered;
    std::printf("  %-8s %-22s %12.2f  %s%s\n", di == 0 ? "behind" : "front", si == 0 ? "default (CAM strategy)" : "ankle strategy alone",
                r.bracket.max_recovered, r.bracket.reached_max ? "none: every push tried recovered" : fmt::format("{:.2f}", r.bracket.min_lost).c_str(),
                r.failed ? fmt::format(" (search failed: {})", r.failure).c_str() : r.inconclusive ? " (a trial stayed inconclusive: may be low)" : "");
  }
  for (int di = 0; di < 2; ++di) {
    std::printf("  from %s: the default controller recovers x%.2f what the ankle strategy alone does\n", di == 0 ? "behind" : "the front",
                largest[di][1] > 0 ? largest[di][0] / largest[di][1] : 0.0);
  }
  std::printf("\n%s", hpr::experiments::kOutcomeLegend);
  return 0;
}

// push_tune for the new robot (its pushes scaled as --verify's), and its result as an overlay
// beside the configuration: FILE.yaml -> FILE.tuned.yaml.
int tune(const std::string& config, const hpr::onboard::RobotDraft& draft, int jobs, int evaluations) {
  namespace fs = std::filesystem;
  const fs::path cfg(config);
  const fs::path out = cfg.parent_path() / (cfg.stem().string() + "-tune");
  const fs::path overlay = cfg.parent_path() / (cfg.stem().string() + ".tuned.yaml");
  const PushScale scale = push_scale(draft);
  std::vector<std::string> a{(fs::path(hpr::launch::executable_dir()) / "push_tune").string(), "--robot", config, "--peak",
                             fmt::format("{:.0f}", scale.peak), "--start", fmt::format("{:.1f}", scale.start), "--max-impulse",
                             fmt::format("{:.1f}", scale.max_impulse), "--resolution", fmt::format("{:.2f}", scale.resolution),
                             "--jobs", std::to_string(jobs), "--out", out.string()};
  if (evaluations > 0) a.insert(a.end(), {"--evaluations", std::to_string(evaluations)});
  std::string line;
  for (const auto& x : a) line += (line.empty() ? "" : " ") + x;
  std::printf("tune: %s\n", line.c_str());
  std::fflush(stdout);
  if (const int rc = hpr::launch::run_to_completion(a); rc != 0) {
    std::printf("tune: push_tune failed (exit %d); its results so far are in %s (push_tune --resume)\n", rc, out.string().c_str());
    return 1;
  }
  fs::copy_file(out / "tuned.yaml", overlay, fs::copy_options::overwrite_existing);
  std::printf("tune: overlay %s (push_trial, push_sweep and push_tune take it with --overlay %s)\n", overlay.string().c_str(),
              overlay.string().c_str());
  return 0;
}

// `command`: the arguments after "init" as given, for the file's header.
int init(hpr::ArgReader& args, const std::string& command) {
  std::string urdf, out;
  bool force = false, check_stand = false;
  int jobs = static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
  bool run_tune = false;
  int evaluations = 0;
  hpr::onboard::DraftOptions options;
  hpr::model::UrdfOptions urdf_options;
  while (args.next()) {
    if (args.is("--out")) {
      out = args.value();
    } else if (args.is("--name")) {
      options.name = args.value();
    } else if (args.is("--leg-height")) {
      options.leg_height_fraction = args.number();
      if (options.leg_height_fraction < 0.5 || options.leg_height_fraction > 0.999) {
        throw hpr::UsageError("--leg-height: must be in [0.5, 0.999]");
      }
    } else if (args.is("--hold")) {
      options.hold.push_back(args.value());
    } else if (args.is("--keep")) {
      options.keep.push_back(args.value());
    } else if (args.is("--mesh-path")) {
      urdf_options.mesh_search_paths.push_back(args.value());
    } else if (args.is("--base")) {
      options.base_link = args.value();
    } else if (args.is("--force")) {
      force = true;
    } else if (args.is("--verify")) {
      check_stand = true;
    } else if (args.is("--tune")) {
      run_tune = true;
    } else if (args.is("--tune-evaluations")) {
      evaluations = static_cast<int>(args.number());
      if (evaluations < 1) throw hpr::UsageError("--tune-evaluations: at least 1");
    } else if (args.is("--jobs")) {
      jobs = static_cast<int>(args.number());
      if (jobs < 1) throw hpr::UsageError("--jobs: at least 1");
    } else if (args.positional() && urdf.empty()) {
      urdf = args.current();
    } else {
      args.unknown();
    }
  }
  if (urdf.empty()) throw hpr::UsageError("init: no URDF given");
  if (out.empty()) throw hpr::UsageError("init: --out FILE.yaml is required");
  namespace fs = std::filesystem;
  if (fs::exists(out) && !force) {
    std::cerr << "hpr_robot: " << out << " exists (--force to overwrite)\n";
    return 2;
  }
  try {
    const auto description = hpr::model::load_urdf(urdf, urdf_options);
    const auto draft = hpr::onboard::draft_robot(description, options);
    const fs::path out_dir = fs::absolute(out).parent_path();
    const std::string urdf_rel = fs::relative(fs::absolute(urdf), out_dir).string();
    std::vector<std::string> mesh_rel;
    for (const auto& p : urdf_options.mesh_search_paths) mesh_rel.push_back(fs::relative(fs::absolute(p), out_dir).string());
    const std::string text = hpr::onboard::write_config(draft, read_file(hpr::experiments::find_in_config_dirs("templates/robot.yaml")), urdf_rel,
                                                        command, mesh_rel);
    // Written beside its final place (relative paths resolve the same) and loaded as every process
    // reads it before it takes that place: a failed init leaves nothing behind.
    const std::string partial = out + ".partial";
    fs::create_directories(out_dir);
    {
      std::ofstream f(partial);
      f << text;
      if (!f) throw std::runtime_error("cannot write " + partial);
    }
    try {
      (void)hpr::model::RobotSpec::load(hpr::Config::load(partial).section("robot"));
    } catch (...) {
      fs::remove(partial);
      throw;
    }
    fs::rename(partial, out);
    for (const auto& r : description.repairs) std::printf("repair: %s\n", r.c_str());
    for (const auto& n : draft.notes) std::printf("%s\n", n.c_str());
    std::printf("wrote %s\n", out.c_str());
    if (check_stand) {
      const int rc = verify(fs::absolute(out).string(), draft, jobs);
      if (rc != 0) return rc;
    }
    if (run_tune) return tune(fs::absolute(out).string(), draft, jobs, evaluations);
  } catch (const hpr::model::ModelError& e) {
    std::cerr << "hpr_robot: " << e.what() << "\n";
    return 1;
  } catch (const hpr::ConfigError& e) {
    std::cerr << "hpr_robot: the configuration drafted for " << out << " does not load (nothing written): " << e.what() << "\n";
    return 1;
  } catch (const std::runtime_error& e) {
    std::cerr << "hpr_robot: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

int check(hpr::ArgReader& args) {
  std::string urdf, base;
  hpr::model::UrdfOptions options;
  while (args.next()) {
    if (args.is("--mesh-path")) {
      options.mesh_search_paths.push_back(args.value());
    } else if (args.is("--base")) {
      base = args.value();
    } else if (args.positional() && urdf.empty()) {
      urdf = args.current();
    } else {
      args.unknown();
    }
  }
  if (urdf.empty()) throw hpr::UsageError("check: no URDF given");
  const auto t0 = std::chrono::steady_clock::now();
  try {
    const auto description = hpr::model::load_urdf(urdf, options);
    hpr::model::ModelOptions mo;
    mo.base_link = base;
    const auto model = hpr::model::Model::build(description, mo);
    std::cout << hpr::onboard::check_report(description, model);
  } catch (const hpr::model::ModelError& e) {
    std::cerr << "hpr_robot: " << e.what() << "\n";
    return 1;
  }
  std::printf("checked in %.2f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    hpr::ArgReader args(argc, argv);
    if (!args.next() || args.is("--help", "-h")) {
      std::cout << kUsage;
      return argc < 2 ? 2 : 0;
    }
    if (args.is("check")) return check(args);
    if (args.is("init")) {
      std::string command;
      for (int i = 2; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--jobs" || a == "--tune-evaluations") {
          ++i;
          continue;
        }
        if (a != "--force" && a != "--verify" && a != "--tune") command += (command.empty() ? "" : " ") + a;
      }
      return init(args, command);
    }
    throw hpr::UsageError("unknown command '" + args.current() + "'");
  } catch (const hpr::UsageError& e) {
    std::cerr << "hpr_robot: " << e.what() << "\n\n" << kUsage;
    return 2;
  }
}
