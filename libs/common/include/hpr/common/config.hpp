#pragma once
/// \file
/// YAML configuration, validated on load. Every accessor checks presence, type and range, and a
/// failure throws ConfigError whose message names the file, the line, the full key and the value:
///
///     config/toro.yaml:42: wbc.com.stiffness = -5: must be in [0, 1e+06]
///
/// A Config is a view on one mapping of a loaded file; sections share the underlying document.
///
/// The document remembers which keys were read (looked up, present or not) and which sections
/// were entered. check_all_read() then refuses what a process that has read its configuration did
/// not understand: a key no code read in a section it entered (a misspelt key, with the nearest
/// name read there), and an override (--set) of a key it neither read nor leaves to another
/// process.

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace YAML {
class Node;
}

namespace hpr {

/// A configuration error: the message says which file, key and value, and what is expected.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Config {
 public:
  static constexpr double kInf = std::numeric_limits<double>::infinity();

  /// Loads `path`. `overrides` are "dotted.key=value" strings applied before any validation, the
  /// value parsed as YAML (so "a.b=[1, 2]" sets a list).
  static Config load(const std::string& path, const std::vector<std::string>& overrides = {});
  /// Parses a YAML document held in memory; `name` stands for the file name in messages.
  static Config parse(std::string_view yaml, std::string name);

  Config(const Config&);
  Config& operator=(const Config&);
  Config(Config&&) noexcept;
  Config& operator=(Config&&) noexcept;
  ~Config();

  /// A required sub-mapping.
  [[nodiscard]] Config section(std::string_view key) const;
  [[nodiscard]] bool has(std::string_view key) const;
  /// True when the key holds a single value (not a list or mapping).
  [[nodiscard]] bool is_scalar(std::string_view key) const;

  [[nodiscard]] double real(std::string_view key, double lo = -kInf, double hi = kInf) const;
  [[nodiscard]] double real_or(std::string_view key, double fallback, double lo = -kInf,
                               double hi = kInf) const;
  [[nodiscard]] long integer(std::string_view key, long lo = std::numeric_limits<long>::min(),
                             long hi = std::numeric_limits<long>::max()) const;
  [[nodiscard]] long integer_or(std::string_view key, long fallback,
                                long lo = std::numeric_limits<long>::min(),
                                long hi = std::numeric_limits<long>::max()) const;
  [[nodiscard]] bool boolean(std::string_view key) const;
  [[nodiscard]] bool boolean_or(std::string_view key, bool fallback) const;
  [[nodiscard]] std::string string(std::string_view key) const;
  [[nodiscard]] std::string string_or(std::string_view key, std::string fallback) const;
  /// A string that must be one of `choices`.
  [[nodiscard]] std::string choice(std::string_view key, const std::vector<std::string>& choices) const;
  [[nodiscard]] std::string choice_or(std::string_view key, std::string fallback,
                                      const std::vector<std::string>& choices) const;
  /// A list of numbers; `size` < 0 accepts any length.
  [[nodiscard]] std::vector<double> reals(std::string_view key, long size = -1, double lo = -kInf,
                                          double hi = kInf) const;
  [[nodiscard]] std::vector<std::string> strings(std::string_view key) const;
  [[nodiscard]] Eigen::Vector3d vec3(std::string_view key, double lo = -kInf, double hi = kInf) const;
  [[nodiscard]] Eigen::Vector3d vec3_or(std::string_view key, const Eigen::Vector3d& fallback,
                                        double lo = -kInf, double hi = kInf) const;
  /// A file path; a relative path is resolved against the directory of the configuration file.
  [[nodiscard]] std::string file_path(std::string_view key) const;
  /// The elements of a required list of mappings, each a Config named "key[i]".
  [[nodiscard]] std::vector<Config> items(std::string_view key) const;
  /// Keys of this mapping, in file order.
  [[nodiscard]] std::vector<std::string> keys() const;
  /// Throws if the mapping holds a key not in `known` (catches misspelt keys).
  void reject_unknown(const std::vector<std::string>& known) const;
  /// Marks `keys` of this mapping as read: keys of a shared section that another process reads.
  void known(const std::vector<std::string>& keys) const;
  /// Throws ConfigError for the first key of an entered section that was never read (naming the
  /// file, line and full key, and the nearest key read there), and for an override of a key that
  /// was not read although its section was, or whose top-level section the file does not have.
  /// Call on the root once everything is loaded.
  void check_all_read() const;

  /// The file this configuration came from and the dotted path of this section.
  [[nodiscard]] const std::string& file() const;
  [[nodiscard]] const std::string& prefix() const { return prefix_; }
  [[nodiscard]] std::string full_key(std::string_view key) const;
  /// Throws ConfigError naming `key` of this section, its value and `what`.
  [[noreturn]] void fail(std::string_view key, std::string_view what) const;
  /// The underlying YAML node (for tools that print or re-emit the configuration).
  [[nodiscard]] const YAML::Node& yaml() const;

 private:
  struct Doc;
  Config(std::shared_ptr<const Doc> doc, std::unique_ptr<YAML::Node> node, std::string prefix);
  [[nodiscard]] YAML::Node child(std::string_view key) const;
  [[nodiscard]] YAML::Node required(std::string_view key) const;
  [[nodiscard]] std::string where(const YAML::Node& n) const;

  std::shared_ptr<const Doc> doc_;
  std::unique_ptr<YAML::Node> node_;
  std::string prefix_;
};

}  // namespace hpr
