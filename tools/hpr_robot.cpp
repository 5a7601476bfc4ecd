// hpr_robot: onboarding a robot description.
//
//   hpr_robot check URDF [--mesh-path DIR]... [--base LINK]
//
// Loads the URDF as the stack does (with the loader's repairs reported), builds the model and
// prints its tree, joint counts, mass, centre of mass, meshes and candidate feet with their soles.
#include <chrono>
#include <cstdio>
#include <iostream>

#include "hpr/common/args.hpp"
#include "hpr/model/model.hpp"
#include "hpr/onboard/robot_check.hpp"

namespace {

constexpr const char* kUsage = R"(usage: hpr_robot check URDF [options]

Reads a robot description as the stack does and reports what a configuration needs: the kinematic
tree, joints by type, total mass and centre of mass, every repair the loader made (massless
<inertial>, regularised inertias, locked mimic joints), the meshes, and the candidate feet with the
sole rectangle their collision geometry gives.

  --mesh-path DIR   a folder where package:// and relative mesh paths are looked up (repeatable;
                    HPR_MESH_PATH and ROS_PACKAGE_PATH are used too)
  --base LINK       floating base (default: the URDF root, or the child of its floating joint)

Exit status: 0 the description loads, 1 it does not (the error names the file, element and value),
2 bad arguments.
)";

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
    throw hpr::UsageError("unknown command '" + args.current() + "'");
  } catch (const hpr::UsageError& e) {
    std::cerr << "hpr_robot: " << e.what() << "\n\n" << kUsage;
    return 2;
  }
}
