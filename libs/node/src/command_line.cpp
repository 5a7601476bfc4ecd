#include "hpr/node/command_line.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "hpr/common/text.hpp"

namespace hpr::node {

CommandLine CommandLine::parse(int argc, char** argv, const std::string& process, const std::string& summary,
                               bool config_required) {
  CommandLine cl;
  cl.name = process;
  auto usage = [&](std::FILE* out) {
    fmt::print(out,
               "{}: {}\n\n"
               "usage: {} --config FILE [--set key=value ...] [--lcm-url URL] [--name NAME]\n"
               "  --config FILE     robot and stack configuration (YAML), e.g. config/toro.yaml\n"
               "  --set key=value   override one configuration value (dotted key, YAML value)\n"
               "  --lcm-url URL     LCM URL (default: lcm.url in the file, else $LCM_DEFAULT_URL)\n"
               "  --name NAME       instance name reported in HEALTH\n",
               process, summary, process);
  };
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    // --option value, or --option=value.
    const auto eq = arg.rfind("--", 0) == 0 ? arg.find('=') : std::string_view::npos;
    const std::string_view a = arg.substr(0, eq);
    auto value = [&](std::string_view flag) -> std::string {
      if (eq != std::string_view::npos) return std::string(arg.substr(eq + 1));
      if (i + 1 >= argc) {
        fmt::print(stderr, "{}: {} needs a value\n", process, flag);
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      usage(stdout);
      std::exit(0);
    } else if (a == "--config") {
      cl.config_path = value(a);
    } else if (a == "--set") {
      cl.overrides.push_back(value(a));
    } else if (a == "--lcm-url") {
      cl.lcm_url = value(a);
    } else if (a == "--name") {
      cl.name = value(a);
    } else {
      // Nothing else is read here: a typo must not run a node with defaults (--lcm_url for
      // --lcm-url would join another robot's LCM group).
      if (arg.rfind("-", 0) == 0) {
        fmt::print(stderr, "{}: unknown option {}{}\n", process, arg,
                   did_you_mean(a, {"--config", "--set", "--lcm-url", "--name", "--help"}));
      } else {
        fmt::print(stderr, "{}: unexpected argument '{}'\n", process, arg);
      }
      fmt::print(stderr, "(run {} --help for the options)\n", process);
      std::exit(2);
    }
  }
  if (config_required && cl.config_path.empty()) {
    usage(stderr);
    fmt::print(stderr, "\n{}: --config is required\n", process);
    std::exit(2);
  }
  return cl;
}

}  // namespace hpr::node
