#include "hpr/common/config.hpp"
#include "hpr/common/text.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <set>

namespace hpr {

struct Config::Doc {
  std::string file;
  YAML::Node root;
  std::vector<std::string> override_keys;  ///< dotted keys set by overrides
  std::set<std::string> file_top_keys;     ///< top-level keys of the file before overrides
  // What the process read: full keys looked up, sections entered, subtrees read as raw YAML.
  mutable std::set<std::string> read, entered, opaque;
};

namespace {

std::string scalar_text(const YAML::Node& n) {
  if (!n.IsDefined() || n.IsNull()) return "null";
  if (n.IsScalar()) return n.Scalar();
  YAML::Emitter e;
  e.SetMapFormat(YAML::Flow);
  e.SetSeqFormat(YAML::Flow);
  e << n;
  return e.c_str();
}

std::vector<std::string> split_dots(std::string_view key) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (start <= key.size()) {
    const size_t dot = key.find('.', start);
    const size_t end = dot == std::string_view::npos ? key.size() : dot;
    parts.emplace_back(key.substr(start, end - start));
    if (dot == std::string_view::npos) break;
    start = dot + 1;
  }
  return parts;
}

// Sets root[a][b][c] = value for "a.b.c=value", creating mappings as needed.
void apply_override(YAML::Node root, const std::string& file, const std::string& text) {
  const size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw ConfigError(fmt::format("{}: override '{}' is not of the form key=value", file, text));
  }
  const std::string key = text.substr(0, eq);
  YAML::Node value;
  try {
    value = YAML::Load(text.substr(eq + 1));
  } catch (const YAML::Exception& e) {
    throw ConfigError(fmt::format("{}: override '{}': value is not valid YAML: {}", file, text, e.msg));
  }
  const auto parts = split_dots(key);
  std::vector<YAML::Node> chain{root};
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    YAML::Node next = chain.back()[parts[i]];
    if (next.IsDefined() && !next.IsNull() && !next.IsMap()) {
      throw ConfigError(fmt::format("{}: override '{}': '{}' is not a mapping", file, text, parts[i]));
    }
    chain.push_back(next);
  }
  chain.back()[parts.back()] = value;
}

}  // namespace

Config::Config(std::shared_ptr<const Doc> doc, std::unique_ptr<YAML::Node> node, std::string prefix)
    : doc_(std::move(doc)), node_(std::move(node)), prefix_(std::move(prefix)) {}

Config::Config(const Config& o) : doc_(o.doc_), node_(std::make_unique<YAML::Node>(*o.node_)), prefix_(o.prefix_) {}
Config& Config::operator=(const Config& o) {
  if (this != &o) {
    doc_ = o.doc_;
    node_ = std::make_unique<YAML::Node>(*o.node_);
    prefix_ = o.prefix_;
  }
  return *this;
}
Config::Config(Config&&) noexcept = default;
Config& Config::operator=(Config&&) noexcept = default;
Config::~Config() = default;

Config Config::load(const std::string& path, const std::vector<std::string>& overrides) {
  auto doc = std::make_shared<Doc>();
  doc->file = path;
  if (!std::filesystem::exists(path)) {
    throw ConfigError(fmt::format("{}: configuration file not found", path));
  }
  if (std::filesystem::is_directory(path)) {
    const std::string folder = std::filesystem::path(path).lexically_normal().string();
    throw ConfigError(fmt::format("{}: is a folder; give a configuration file (e.g. {}{}toro.yaml)", path, folder,
                                  folder.ends_with('/') ? "" : "/"));
  }
  try {
    doc->root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw ConfigError(fmt::format("{}:{}: YAML syntax error: {}", path, e.mark.line + 1, e.msg));
  }
  if (!doc->root.IsMap()) throw ConfigError(fmt::format("{}: the top level must be a mapping", path));
  for (const auto& kv : doc->root) {
    if (kv.first.IsScalar()) doc->file_top_keys.insert(kv.first.Scalar());
  }
  for (const auto& o : overrides) {
    apply_override(doc->root, path, o);
    doc->override_keys.push_back(o.substr(0, o.find('=')));
  }
  auto node = std::make_unique<YAML::Node>(doc->root);
  return Config(std::move(doc), std::move(node), "");
}

Config Config::parse(std::string_view yaml, std::string name) {
  auto doc = std::make_shared<Doc>();
  doc->file = std::move(name);
  try {
    doc->root = YAML::Load(std::string(yaml));
  } catch (const YAML::Exception& e) {
    throw ConfigError(fmt::format("{}:{}: YAML syntax error: {}", doc->file, e.mark.line + 1, e.msg));
  }
  if (!doc->root.IsMap()) throw ConfigError(fmt::format("{}: the top level must be a mapping", doc->file));
  auto node = std::make_unique<YAML::Node>(doc->root);
  return Config(std::move(doc), std::move(node), "");
}

const std::string& Config::file() const { return doc_->file; }
const YAML::Node& Config::yaml() const {
  doc_->opaque.insert(prefix_);
  return *node_;
}

std::string Config::full_key(std::string_view key) const {
  return prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key);
}

std::string Config::where(const YAML::Node& n) const {
  if (n.IsDefined() && !n.Mark().is_null()) return fmt::format("{}:{}", doc_->file, n.Mark().line + 1);
  if (!node_->Mark().is_null()) return fmt::format("{}:{}", doc_->file, node_->Mark().line + 1);
  return doc_->file;
}

YAML::Node Config::child(std::string_view key) const {
  doc_->read.insert(full_key(key));
  if (!node_->IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  return (*node_)[std::string(key)];
}

YAML::Node Config::required(std::string_view key) const {
  YAML::Node n = child(key);
  if (!n.IsDefined() || n.IsNull()) {
    throw ConfigError(fmt::format("{}: missing key '{}'", where(*node_), full_key(key)));
  }
  return n;
}

void Config::fail(std::string_view key, std::string_view what) const {
  const YAML::Node n = child(key);
  throw ConfigError(fmt::format("{}: {} = {}: {}", where(n), full_key(key), scalar_text(n), what));
}

bool Config::has(std::string_view key) const {
  const YAML::Node n = child(key);
  return n.IsDefined() && !n.IsNull();
}

bool Config::is_scalar(std::string_view key) const {
  const YAML::Node n = child(key);
  return n.IsDefined() && n.IsScalar();
}

Config Config::section(std::string_view key) const {
  YAML::Node n = required(key);
  if (!n.IsMap()) fail(key, "expected a mapping");
  doc_->entered.insert(full_key(key));
  return Config(doc_, std::make_unique<YAML::Node>(n), full_key(key));
}

std::vector<Config> Config::items(std::string_view key) const {
  const YAML::Node n = required(key);
  if (!n.IsSequence()) fail(key, "expected a list");
  std::vector<Config> out;
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string name = full_key(key) + "[" + std::to_string(i) + "]";
    if (!n[i].IsMap()) {
      throw ConfigError(fmt::format("{}: {} = {}: expected a mapping", where(n[i]), name, scalar_text(n[i])));
    }
    doc_->entered.insert(name);
    out.push_back(Config(doc_, std::make_unique<YAML::Node>(n[i]), name));
  }
  return out;
}

std::vector<std::string> Config::keys() const {
  std::vector<std::string> out;
  if (!node_->IsMap()) return out;
  for (const auto& kv : *node_) {
    // A key must be a plain name: YAML allows lists and mappings as keys ("? [a, b]: 1").
    if (!kv.first.IsScalar()) {
      throw ConfigError(fmt::format("{}: {}: a key that is not a plain name", where(kv.first), prefix_.empty() ? "(top level)" : prefix_));
    }
    out.push_back(kv.first.Scalar());
    doc_->read.insert(full_key(kv.first.Scalar()));  // enumerated: the caller decides about each
  }
  return out;
}

void Config::known(const std::vector<std::string>& keys) const {
  for (const auto& k : keys) doc_->read.insert(full_key(k));
}

namespace {

/// The names read directly under `prefix` (for "did you mean").
std::vector<std::string> read_names_under(const std::set<std::string>& read, const std::string& prefix) {
  std::vector<std::string> out;
  const std::string head = prefix.empty() ? "" : prefix + ".";
  for (const auto& k : read) {
    if (k.size() <= head.size() || k.compare(0, head.size(), head) != 0) continue;
    const std::string rest = k.substr(head.size());
    if (rest.find('.') == std::string::npos && rest.find('[') == std::string::npos) out.push_back(rest);
  }
  return out;
}

bool under_opaque(const std::set<std::string>& opaque, const std::string& key) {
  for (const auto& o : opaque) {
    if (key == o || key.rfind(o + ".", 0) == 0 || key.rfind(o + "[", 0) == 0) return true;
  }
  return false;
}

}  // namespace

void Config::check_all_read() const {
  const Doc& d = *doc_;
  // Every key of an entered section must have been read, recursively (overrides first, so that
  // a misspelt --set is reported as such).
  const std::function<void(const YAML::Node&, const std::string&)> walk = [&](const YAML::Node& map, const std::string& prefix) {
    if (under_opaque(d.opaque, prefix)) return;
    for (const auto& kv : map) {
      if (!kv.first.IsScalar()) continue;
      const std::string full = prefix + "." + kv.first.Scalar();
      if (d.read.count(full) == 0) {
        const std::string line = kv.first.Mark().is_null() ? d.file : fmt::format("{}:{}", d.file, kv.first.Mark().line + 1);
        throw ConfigError(fmt::format("{}: {}: unknown key{} (not read by this process; a misspelt key would be ignored)", line,
                                      full, did_you_mean(kv.first.Scalar(), read_names_under(d.read, prefix))));
      }
      if (kv.second.IsMap() && d.entered.count(full) != 0) walk(kv.second, full);
      if (kv.second.IsSequence()) {
        for (std::size_t i = 0; i < kv.second.size(); ++i) {
          const std::string item = full + "[" + std::to_string(i) + "]";
          if (kv.second[i].IsMap() && d.entered.count(item) != 0) walk(kv.second[i], item);
        }
      }
    }
  };
  // Overrides: read here, or in a section this process leaves to others.
  for (const auto& key : d.override_keys) {
    if (d.read.count(key) != 0 || under_opaque(d.opaque, key)) continue;
    const std::string top = key.substr(0, key.find('.'));
    if (d.entered.count(top) == 0 && d.file_top_keys.count(top) != 0) continue;  // another process's section
    if (d.file_top_keys.count(top) == 0) {
      std::vector<std::string> tops(d.file_top_keys.begin(), d.file_top_keys.end());
      throw ConfigError(fmt::format("{}: override {}: the file has no section '{}'{}", d.file, key, top, did_you_mean(top, tops)));
    }
    const std::string parent = key.substr(0, key.rfind('.'));
    throw ConfigError(fmt::format("{}: override {}: unknown key (not read by this process){}", d.file, key,
                                  did_you_mean(key.substr(key.rfind('.') + 1), read_names_under(d.read, parent))));
  }
  for (const auto& kv : d.root) {
    if (kv.first.IsScalar() && kv.second.IsMap() && d.entered.count(kv.first.Scalar()) != 0) walk(kv.second, kv.first.Scalar());
  }
}

void Config::reject_unknown(const std::vector<std::string>& known) const {
  for (const auto& k : keys()) {
    if (std::find(known.begin(), known.end(), k) == known.end()) {
      std::string list;
      for (const auto& s : known) list += (list.empty() ? "" : ", ") + s;
      fail(k, fmt::format("unknown key{} (expected one of: {})", did_you_mean(k, known), list));
    }
  }
}

namespace {
bool parse_double(const YAML::Node& n, double* out) {
  if (!n.IsScalar()) return false;
  const std::string& s = n.Scalar();
  if (s == ".inf" || s == "inf") { *out = std::numeric_limits<double>::infinity(); return true; }
  if (s == "-.inf" || s == "-inf") { *out = -std::numeric_limits<double>::infinity(); return true; }
  try {
    size_t used = 0;
    *out = std::stod(s, &used);
    return used == s.size();
  } catch (...) {
    return false;
  }
}
}  // namespace

double Config::real(std::string_view key, double lo, double hi) const {
  const YAML::Node n = required(key);
  double v = 0;
  if (!parse_double(n, &v) || std::isnan(v)) fail(key, "expected a number");
  if (v < lo || v > hi) fail(key, fmt::format("must be in [{}, {}]", lo, hi));
  return v;
}

double Config::real_or(std::string_view key, double fallback, double lo, double hi) const {
  return has(key) ? real(key, lo, hi) : fallback;
}

long Config::integer(std::string_view key, long lo, long hi) const {
  const YAML::Node n = required(key);
  long v = 0;
  try {
    if (!n.IsScalar()) throw YAML::Exception(YAML::Mark::null_mark(), "");
    size_t used = 0;
    v = std::stol(n.Scalar(), &used);
    if (used != n.Scalar().size()) throw YAML::Exception(YAML::Mark::null_mark(), "");
  } catch (...) {
    fail(key, "expected an integer");
  }
  if (v < lo || v > hi) fail(key, fmt::format("must be in [{}, {}]", lo, hi));
  return v;
}

long Config::integer_or(std::string_view key, long fallback, long lo, long hi) const {
  return has(key) ? integer(key, lo, hi) : fallback;
}

bool Config::boolean(std::string_view key) const {
  const YAML::Node n = required(key);
  bool v = false;
  if (!n.IsScalar() || !YAML::convert<bool>::decode(n, v)) fail(key, "expected true or false");
  return v;
}

bool Config::boolean_or(std::string_view key, bool fallback) const {
  return has(key) ? boolean(key) : fallback;
}

std::string Config::string(std::string_view key) const {
  const YAML::Node n = required(key);
  if (!n.IsScalar()) fail(key, "expected a string");
  return n.Scalar();
}

std::string Config::string_or(std::string_view key, std::string fallback) const {
  return has(key) ? string(key) : std::move(fallback);
}

std::string Config::choice(std::string_view key, const std::vector<std::string>& choices) const {
  std::string v = string(key);
  if (std::find(choices.begin(), choices.end(), v) == choices.end()) {
    std::string list;
    for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
    fail(key, fmt::format("must be one of: {}", list));
  }
  return v;
}

std::string Config::choice_or(std::string_view key, std::string fallback,
                              const std::vector<std::string>& choices) const {
  return has(key) ? choice(key, choices) : std::move(fallback);
}

std::vector<double> Config::reals(std::string_view key, long size, double lo, double hi) const {
  const YAML::Node n = required(key);
  if (!n.IsSequence()) fail(key, "expected a list of numbers");
  if (size >= 0 && static_cast<long>(n.size()) != size) {
    fail(key, fmt::format("expected {} numbers, got {}", size, n.size()));
  }
  std::vector<double> out;
  out.reserve(n.size());
  for (size_t i = 0; i < n.size(); ++i) {
    double v = 0;
    if (!parse_double(n[i], &v) || std::isnan(v)) fail(key, fmt::format("element {} is not a number", i));
    if (v < lo || v > hi) fail(key, fmt::format("element {} must be in [{}, {}]", i, lo, hi));
    out.push_back(v);
  }
  return out;
}

std::vector<std::string> Config::strings(std::string_view key) const {
  const YAML::Node n = required(key);
  if (!n.IsSequence()) fail(key, "expected a list of strings");
  std::vector<std::string> out;
  for (size_t i = 0; i < n.size(); ++i) {
    if (!n[i].IsScalar()) fail(key, fmt::format("element {} is not a string", i));
    out.push_back(n[i].Scalar());
  }
  return out;
}

Eigen::Vector3d Config::vec3(std::string_view key, double lo, double hi) const {
  const auto v = reals(key, 3, lo, hi);
  return {v[0], v[1], v[2]};
}

Eigen::Vector3d Config::vec3_or(std::string_view key, const Eigen::Vector3d& fallback, double lo,
                                double hi) const {
  return has(key) ? vec3(key, lo, hi) : fallback;
}

std::string Config::file_path(std::string_view key) const {
  const std::string p = string(key);
  std::filesystem::path path(p);
  if (path.is_relative()) {
    path = std::filesystem::path(doc_->file).parent_path() / path;
  }
  if (!std::filesystem::exists(path)) fail(key, fmt::format("file not found: {}", path.string()));
  return std::filesystem::weakly_canonical(path).string();
}

}  // namespace hpr
