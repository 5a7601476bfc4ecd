#pragma once
/// \file
/// A node's live parameters on the wire: the OPERATOR sets and gets addressed to it, applied
/// between two steps, and PARAMS, which answers each of them and announces the values when the
/// node starts. A process that runs several components (the composed controllers) keeps one set
/// per component under the component's process name, so an OPERATOR set addressed to
/// "wbc.com.stiffness.z" reaches the wbc wherever it runs, and PARAMS answers in that name.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hpr/common/parameters.hpp"

namespace hpr::node {

class Health;
class Transport;

/// An OPERATOR request answered on PARAMS.
struct ParameterRequest {
  std::int64_t utime = 0;
  std::string source;
  bool accepted = false;
  std::string result;
};

class ParameterServer {
 public:
  /// Answers through `transport`; PARAMS carries `health`'s last tick.
  ParameterServer(Transport& transport, const Health& health) : transport_(transport), health_(health) {}

  /// The live parameters answered under the name `node`. The first call subscribes to OPERATOR.
  ParameterSet& parameters(const std::string& node);
  /// Publishes PARAMS of `set`: the current values, and the answer to the request `request` (may be null).
  void publish(const ParameterSet& set, const ParameterRequest* request);
  /// Once the loop runs: publishes every set's values (PARAMS "started").
  void announce_once();

 private:
  Transport& transport_;
  const Health& health_;
  std::vector<std::unique_ptr<ParameterSet>> sets_;  ///< one per name answered
  bool announced_ = false;
  std::string last_request_;  ///< source and utime of the last OPERATOR request handled (copies repeat it)
};

}  // namespace hpr::node
