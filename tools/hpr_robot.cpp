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

#include "hpr/common/args.hpp"
#include "hpr/experiments/trial.hpp"
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
of the leg chains) with their soles from the collision geometry, the IMU (a link named imu on the
base, else the base), held joints (hands, fingers, grippers, head: names containing hand, finger,
thumb, index, middle, ring, pinky, little, gripper, head, neck, eye), a standing posture by inverse
kinematics (hips at a fraction of the straight leg above the soles, soles flat, CoM over their
middle, shoulders 0.15 rad out, elbows bent 0.4 rad), segments, the motion optimiser's adjusted
coordinates (base rotation, torso, first four joints of each arm) and gains scaled to the robot's
mass and inertia; the rest is the stack's defaults (config/templates/robot.yaml).

  --out FILE            the configuration to write (required; an existing file is not overwritten
                        without --force)
  --name NAME           robot name (default: the URDF's)
  --leg-height F        hips at F times the straight leg's length above the soles (default 0.90)
  --hold JOINT          hold this joint too (repeatable)
  --keep JOINT          never hold this joint (repeatable)
  --mesh-path DIR, --base LINK   as for check
  --force               overwrite FILE
  --verify              then stand the robot 10 s in the simulator and push it from behind and from
                        the front with the CAM and the ankle strategies (impulses of 0.5 and 1 times
                        the ankle strategy's bound m w d, d the sole's half length)

Exit status: 0 the description loads (init: and with --verify the robot stands), 1 it does not (the
error names the file, element and value), 2 bad arguments.
)";

std::string read_file(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Stands the robot 10 s, then pushes it from behind and from the front with both strategies.
int verify(const std::string& config, const hpr::onboard::RobotDraft& draft) {
  using hpr::experiments::Strategy;
  hpr::experiments::TrialSpec stand;
  stand.config = config;
  stand.impulse = 0.5;
  stand.peak = 5.0;
  stand.push_time = 10.0;
  stand.after = 2.0;
  std::printf("verify: standing 10 s ...\n");
  std::fflush(stdout);
  const auto st = hpr::experiments::run_trial(stand);
  if (st.fallen || st.sim_time < stand.push_time) {
    std::printf("verify: the robot does not stand (%s)\n", st.failure.empty() ? "fell" : st.failure.c_str());
    return 1;
  }
  std::printf("verify: stands 10 s (a 0.5 N s nudge then moved the CoM by %.1f mm at most)\n", 1e3 * st.max_com_deviation);
  const double omega = std::sqrt(9.81 / draft.com_height);
  const double d = 0.5 * draft.feet[0].sole.length;
  const double bound = draft.mass * omega * d;
  std::printf("\n  ankle strategy's bound m w d = %.1f kg x %.2f 1/s x %.3f m = %.1f N s\n\n", draft.mass, omega, d, bound);
  std::printf("  %-8s %-6s %9s  %-10s %14s %13s\n", "from", "strategy", "impulse", "result", "CoP margin mm", "peak CAM Nms");
  for (double dir : {0.0, 180.0}) {
    for (double f : {0.5, 1.0}) {
      for (Strategy s : {Strategy::kCam, Strategy::kAnkle}) {
        hpr::experiments::TrialSpec t;
        t.config = config;
        t.strategy = s;
        t.direction_deg = dir;
        t.impulse = f * bound;
        t.peak = std::max(20.0, 2.0 * draft.mass);
        const auto r = hpr::experiments::run_trial(t);
        std::printf("  %-8s %-8s %7.1f  %-10s %14.1f %13.2f\n", dir == 0.0 ? "behind" : "front", to_string(s), t.impulse,
                    r.recovered ? "recovered" : (r.fallen ? "fell" : "failed"), 1e3 * r.min_cop_margin,
                    r.peak_cam.norm());
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

// `command`: the arguments after "init" as given, for the file's header.
int init(hpr::ArgReader& args, const std::string& command) {
  std::string urdf, out;
  bool force = false, check_stand = false;
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
    if (check_stand) return verify(fs::absolute(out).string(), draft);
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
        if (a != "--force" && a != "--verify") command += (command.empty() ? "" : " ") + a;
      }
      return init(args, command);
    }
    throw hpr::UsageError("unknown command '" + args.current() + "'");
  } catch (const hpr::UsageError& e) {
    std::cerr << "hpr_robot: " << e.what() << "\n\n" << kUsage;
    return 2;
  }
}
