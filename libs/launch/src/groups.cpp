#include "hpr/launch/groups.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <optional>
#include <set>
#include <stdexcept>

#include "hpr/common/config.hpp"

namespace hpr::launch {

namespace {

const std::vector<std::string> kProcessKeys = {
    "command", "args",          "env",     "host",    "depends_on", "ready",        "health_node",
    "ready_timeout", "restart", "backoff", "backoff_max", "max_restarts", "stop_signal", "stop_timeout",
    "cpus", "rt_priority", "critical", "hung_after"};

/// ${name} → its value from `vars`, else the environment; an unknown name fails naming `key` of `where`.
std::string expand(const std::string& text, const std::map<std::string, std::string>& vars, const Config& where,
                   const std::string& key) {
  std::string out;
  std::size_t i = 0;
  while (i < text.size()) {
    const std::size_t s = text.find("${", i);
    if (s == std::string::npos) {
      out += text.substr(i);
      break;
    }
    const std::size_t e = text.find('}', s);
    if (e == std::string::npos) where.fail(key, "unterminated ${ in '" + text + "'");
    out += text.substr(i, s - i);
    const std::string name = text.substr(s + 2, e - s - 2);
    if (auto it = vars.find(name); it != vars.end()) {
      out += it->second;
    } else if (const char* env = std::getenv(name.c_str())) {
      out += env;
    } else {
      where.fail(key, "unknown variable ${" + name + "} (define it under vars: or pass --var " + name + "=...)");
    }
    i = e + 1;
  }
  return out;
}

/// One process key from the process's own section, else from `defaults:`.
struct Source {
  const Config& p;
  const std::optional<Config>& d;
  [[nodiscard]] const Config* of(const std::string& key) const {
    if (p.has(key)) return &p;
    if (d && d->has(key)) return &*d;
    return nullptr;
  }
};

ProcessSpec parse_process(const std::string& name, const Config& p, const std::optional<Config>& defaults,
                          const std::map<std::string, std::string>& vars) {
  p.reject_unknown(kProcessKeys);
  Source src{p, defaults};
  ProcessSpec s;
  s.name = name;
  s.command = expand(p.string("command"), vars, p, "command");
  if (s.command.empty()) p.fail("command", "must not be empty");
  if (const Config* c = src.of("args")) {
    for (const auto& a : c->strings("args")) s.args.push_back(expand(a, vars, *c, "args"));
  }
  if (const Config* c = src.of("env")) {
    const Config env = c->section("env");
    for (const auto& k : env.keys()) s.env[k] = expand(env.string(k), vars, env, k);
  }
  if (const Config* c = src.of("host")) s.host = c->string("host");
  if (p.has("depends_on")) s.depends_on = p.strings("depends_on");
  if (const Config* c = src.of("ready")) s.ready_on = c->choice("ready", {"health", "start"}) == "start" ? ReadyOn::kStart : ReadyOn::kHealth;
  s.health_node = p.string_or("health_node", name);
  if (const Config* c = src.of("ready_timeout")) s.ready_timeout_s = c->real("ready_timeout", 0.1, 3600.0);
  if (const Config* c = src.of("restart")) {
    const std::string r = c->choice("restart", {"never", "on-failure", "always"});
    s.restart = r == "never" ? RestartPolicy::kNever : r == "always" ? RestartPolicy::kAlways : RestartPolicy::kOnFailure;
  }
  if (const Config* c = src.of("backoff")) s.backoff_s = c->real("backoff", 0.0, 3600.0);
  if (const Config* c = src.of("backoff_max")) s.backoff_max_s = c->real("backoff_max", 0.0, 3600.0);
  if (s.backoff_max_s < s.backoff_s) {
    (src.of("backoff_max") != nullptr ? *src.of("backoff_max") : p).fail(src.of("backoff_max") != nullptr ? "backoff_max" : "backoff", "backoff_max must not be below backoff");
  }
  if (const Config* c = src.of("max_restarts")) s.max_restarts = static_cast<int>(c->integer("max_restarts", 0, 1000000));
  if (const Config* c = src.of("stop_signal")) {
    s.stop_signal = signal_number(c->string("stop_signal"));
    if (s.stop_signal < 0) c->fail("stop_signal", "unknown signal (expected SIGTERM, SIGINT, SIGHUP, SIGQUIT, SIGUSR1, SIGUSR2 or SIGKILL)");
  }
  if (const Config* c = src.of("stop_timeout")) s.stop_timeout_s = c->real("stop_timeout", 0.0, 600.0);
  if (const Config* c = src.of("cpus")) {
    for (const double x : c->reals("cpus", -1, 0, 1023)) {
      if (x != static_cast<int>(x)) c->fail("cpus", "CPU numbers must be integers");
      s.cpus.push_back(static_cast<int>(x));
    }
  }
  if (const Config* c = src.of("rt_priority")) s.rt_priority = static_cast<int>(c->integer("rt_priority", 0, 99));
  if (const Config* c = src.of("critical")) s.critical = c->boolean("critical");
  if (const Config* c = src.of("hung_after")) {
    s.hung_after_s = c->real("hung_after", 0.0, 3600.0);
    if (s.hung_after_s > 0 && s.ready_on != ReadyOn::kHealth) {
      // The default does not apply to a process that sends no HEALTH; its own key is a mistake.
      if (c == &p) c->fail("hung_after", "needs ready: health (a process that sends no HEALTH cannot be watched)");
      s.hung_after_s = 0.0;
    }
    if (s.hung_after_s > 0 && s.hung_after_s < 0.01) c->fail("hung_after", "must be 0 (not watched) or at least 0.01 s");
  }
  return s;
}

}  // namespace

int signal_number(const std::string& name) {
  static const std::map<std::string, int> k = {{"TERM", SIGTERM}, {"INT", SIGINT},   {"HUP", SIGHUP},  {"QUIT", SIGQUIT},
                                               {"USR1", SIGUSR1}, {"USR2", SIGUSR2}, {"KILL", SIGKILL}};
  const std::string n = name.rfind("SIG", 0) == 0 ? name.substr(3) : name;
  const auto it = k.find(n);
  return it == k.end() ? -1 : it->second;
}

const char* to_string(RestartPolicy p) {
  switch (p) {
    case RestartPolicy::kNever: return "never";
    case RestartPolicy::kOnFailure: return "on-failure";
    case RestartPolicy::kAlways: return "always";
  }
  return "?";
}

const ProcessSpec* GroupSpec::find(const std::string& n) const {
  for (const auto& p : processes) {
    if (p.name == n) return &p;
  }
  return nullptr;
}

std::vector<std::string> GroupSpec::hosts() const {
  std::vector<std::string> out;
  for (const auto& p : processes) {
    const std::string& h = host_of(p);
    if (!h.empty() && std::find(out.begin(), out.end(), h) == out.end()) out.push_back(h);
  }
  return out;
}

namespace {

/// Merges the included groups' processes into each group, depth first: a group's own processes
/// first (the backend, then the shared control processes), an own process replacing an included
/// one of the same name; a cycle or an unknown group is an error.
void resolve_includes(GroupsFile& f, const Config& groups, std::map<std::string, std::vector<std::string>>& includes) {
  std::map<std::string, int> mark;  // 1 visiting, 2 done
  std::function<void(const std::string&)> resolve = [&](const std::string& gname) {
    if (mark[gname] == 2) return;
    const Config g = groups.section(gname);
    if (mark[gname] == 1) g.fail("include", "groups include each other in a cycle");
    mark[gname] = 1;
    std::vector<ProcessSpec> merged;
    for (const auto& inc : includes[gname]) {
      if (f.groups.count(inc) == 0) g.fail("include", "no group named '" + inc + "'");
      resolve(inc);
      for (const auto& p : f.groups[inc].processes) {
        if (f.groups[gname].find(p.name) == nullptr &&
            std::none_of(merged.begin(), merged.end(), [&](const ProcessSpec& m) { return m.name == p.name; })) {
          merged.push_back(p);
        }
      }
    }
    auto& own = f.groups[gname].processes;
    own.insert(own.end(), merged.begin(), merged.end());
    mark[gname] = 2;
  };
  for (const auto& gname : f.names) resolve(gname);
}

/// A group's overrides apply to every process it runs, its own and the included ones (a lockstep
/// variant of a group runs the same processes without real-time priorities).
void apply_group_overrides(GroupsFile& f, const Config& groups) {
  for (const auto& gname : f.names) {
    const Config g = groups.section(gname);
    if (!g.has("overrides")) continue;
    const Config o = g.section("overrides");
    o.reject_unknown({"rt_priority", "hung_after"});
    for (auto& p : f.groups[gname].processes) {
      if (o.has("rt_priority")) p.rt_priority = static_cast<int>(o.integer("rt_priority", 0, 99));
      if (o.has("hung_after") && p.hung_after_s > 0) p.hung_after_s = o.real("hung_after", 0.01, 3600.0);
    }
  }
}

/// Dependencies: known names, no cycles; the processes put in start order (stable otherwise).
void order_by_dependencies(GroupSpec& g, const Config& gc, const std::string& path) {
  for (const auto& p : g.processes) {
    for (const auto& d : p.depends_on) {
      if (g.find(d) == nullptr) {
        const std::string where = gc.has("processes") && gc.section("processes").has(p.name) ? "" : " (included)";
        throw ConfigError(path + ": groups." + g.name + ".processes." + p.name + ".depends_on = " + d +
                          ": no process of that name in the group" + where);
      }
    }
  }
  std::vector<ProcessSpec> ordered;
  std::set<std::string> placed;
  std::vector<ProcessSpec> left = g.processes;
  while (!left.empty()) {
    auto it = std::find_if(left.begin(), left.end(), [&](const ProcessSpec& p) {
      return std::all_of(p.depends_on.begin(), p.depends_on.end(), [&](const std::string& d) { return placed.count(d) != 0; });
    });
    if (it == left.end()) {
      std::string cycle;
      for (const auto& p : left) cycle += (cycle.empty() ? "" : ", ") + p.name;
      throw ConfigError(path + ": groups." + g.name + ": depends_on forms a cycle among: " + cycle);
    }
    placed.insert(it->name);
    ordered.push_back(*it);
    left.erase(it);
  }
  g.processes = std::move(ordered);
}

}  // namespace

GroupsFile GroupsFile::load(const std::string& path, const std::map<std::string, std::string>& overrides) {
  const Config root = Config::load(path);
  root.reject_unknown({"vars", "defaults", "lcm_url", "groups"});
  GroupsFile f;
  f.path = path;
  std::map<std::string, std::string> vars;
  vars["config_dir"] = std::filesystem::absolute(path).parent_path().lexically_normal().string();
  if (root.has("vars")) {
    const Config v = root.section("vars");
    for (const auto& k : v.keys()) vars[k] = v.string(k);
  }
  for (const auto& [k, v] : overrides) vars[k] = v;
  f.lcm_url = root.has("lcm_url") ? expand(root.string("lcm_url"), vars, root, "lcm_url") : "";
  std::optional<Config> defaults;
  if (root.has("defaults")) {
    defaults = root.section("defaults");
    std::vector<std::string> known = kProcessKeys;
    known.erase(std::remove_if(known.begin(), known.end(), [](const std::string& k) { return k == "command" || k == "depends_on" || k == "health_node"; }), known.end());
    defaults->reject_unknown(known);
  }
  const Config groups = root.section("groups");
  // First every group's own processes, then the includes (which may name groups defined later).
  std::map<std::string, std::vector<std::string>> includes;
  for (const auto& gname : groups.keys()) {
    const Config g = groups.section(gname);
    g.reject_unknown({"description", "default_host", "include", "processes", "overrides"});
    GroupSpec spec;
    spec.name = gname;
    spec.description = g.string_or("description", "");
    spec.default_host = g.string_or("default_host", "");
    if (g.has("include")) includes[gname] = g.strings("include");
    if (g.has("processes")) {
      const Config ps = g.section("processes");
      for (const auto& pname : ps.keys()) spec.processes.push_back(parse_process(pname, ps.section(pname), defaults, vars));
    }
    f.names.push_back(gname);
    f.groups[gname] = std::move(spec);
  }
  resolve_includes(f, groups, includes);
  apply_group_overrides(f, groups);
  for (const auto& gname : f.names) order_by_dependencies(f.groups[gname], groups.section(gname), f.path);
  return f;
}

const GroupSpec& GroupsFile::group(const std::string& name) const {
  const auto it = groups.find(name);
  if (it == groups.end()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    throw std::invalid_argument(path + ": no group named '" + name + "' (groups: " + list + ")");
  }
  return it->second;
}

}  // namespace hpr::launch
