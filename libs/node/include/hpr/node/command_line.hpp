#pragma once
/// \file The command line shared by every process:
///   <process> --config FILE [--set key=value ...] [--lcm-url URL] [--name NAME]

#include <string>
#include <vector>

namespace hpr::node {

struct CommandLine {
  std::string config_path;             ///< --config: the robot/stack YAML file
  std::vector<std::string> overrides;  ///< --set key=value, applied to the YAML before validation
  std::string lcm_url;                 ///< --lcm-url, else lcm.url in the file, else LCM_DEFAULT_URL
  std::string name;                    ///< --name: node instance name in HEALTH (default: the process)

  /// Parses argv. Prints usage and exits 0 on --help; exits 2 with a message on a malformed line,
  /// an unknown option (with the nearest known one) or an unexpected argument.
  static CommandLine parse(int argc, char** argv, const std::string& process, const std::string& summary,
                           bool config_required = true);
};

}  // namespace hpr::node
