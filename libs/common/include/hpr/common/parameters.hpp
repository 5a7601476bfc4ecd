#pragma once
/// \file
/// Parameters an operator may change while a node runs (OPERATOR COMMAND_SET_PARAMS).
///
/// A node registers the scalars it allows to change live, each under the key of its own YAML
/// section ("com.stiffness.z" for `wbc: {com: {stiffness: [x, y, z]}}`) with the range the
/// configuration loader accepts and a unit. An OPERATOR set names them "node.key" = value:
///  - a set is all or nothing: a key the node does not have, a non-finite value, a value outside
///    the range or one the parameter's setter refuses rejects the whole set, and nothing changes;
///  - the runtime applies it between two steps (its LCM callbacks run on the loop thread), so a
///    step never sees half a set;
///  - the node answers on PARAMS with what changed or why nothing did, and the current values.
/// Nothing here is written back to the YAML file: a restart starts from the configuration again.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace hpr {

/// One live-tunable scalar.
struct Parameter {
  std::string key;   ///< as in the node's configuration section, "com.stiffness.z"
  std::string unit;  ///< "N/m", "1/s", "" for a ratio
  double min_value = 0.0, max_value = 0.0;  ///< accepted range, closed
  std::function<double()> get;
  /// Applies a value already inside [min, max]; returns why it is refused ("" when applied). A
  /// setter that refuses must leave everything as it was.
  std::function<std::string(double)> set;
};

/// The outcome of one OPERATOR set for one node.
struct ParameterSetResult {
  bool addressed = false;  ///< some "node.key" named this node
  bool applied = false;    ///< every one of them was applied
  int changed = 0;         ///< parameters whose value changed
  std::string text;        ///< "com.stiffness.z 3000 -> 2500", or why nothing changed
};

class ParameterSet {
 public:
  explicit ParameterSet(std::string node) : node_(std::move(node)) {}

  /// Registers a parameter; throws std::logic_error for a repeated key, an empty range, a
  /// missing getter or setter.
  void add(Parameter p);
  /// Registers `value` itself; `on_change` (optional) runs after it changed, e.g. to recompute
  /// what the node derives from it.
  void add(const std::string& key, double& value, double min_value, double max_value, const std::string& unit,
           std::function<void()> on_change = {});
  /// Registers the three values at `xyz` (an Eigen::Vector3d's data(), say) as "key.x", "key.y", "key.z".
  void add_xyz(const std::string& key, double* xyz, double min_value, double max_value, const std::string& unit);

  /// Applies the pairs of an OPERATOR set whose name starts with "<node>."; the others are for
  /// other nodes and ignored.
  ParameterSetResult apply(const std::vector<std::string>& names, const std::vector<double>& values);

  [[nodiscard]] const std::string& node() const { return node_; }
  [[nodiscard]] const std::vector<Parameter>& parameters() const { return parameters_; }
  [[nodiscard]] const Parameter* find(const std::string& key) const;
  /// Sets applied since the start.
  [[nodiscard]] std::int64_t version() const { return version_; }

 private:
  std::string node_;
  std::vector<Parameter> parameters_;
  std::int64_t version_ = 0;
};

}  // namespace hpr
