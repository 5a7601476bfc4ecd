#pragma once
/// \file
/// The LCM channels the viewer shows, each decoded into JSON with a JSON schema derived from the
/// same conversion (so the schema Foxglove is given cannot drift from the messages it receives).

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace hpr::viewer {

/// A message that does not decode as its channel's type, or a channel the viewer does not know.
class DecodeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ChannelInfo {
  std::string name;         ///< LCM channel, e.g. ROBOT_STATE
  std::string schema_name;  ///< LCM type, e.g. humanoid.robot_state_t
  nlohmann::json schema;    ///< JSON schema (draft 2020-12) of the JSON the channel is decoded into
  /// The message's `utime` is the robot clock (false: wall clock, e.g. HEALTH).
  bool robot_clock = true;
};

/// The channels, in a fixed order (the index is the Foxglove channel id minus one).
const std::vector<ChannelInfo>& channels();
/// Index of `name` in channels(), or -1.
int channel_index(const std::string& name);

struct Decoded {
  nlohmann::json json;
  std::int64_t tick = 0;
  std::int64_t utime = 0;
};

/// Decodes an LCM message of `channel` (with its fingerprint) into JSON. Fields the viewer does
/// not draw are left out; non-finite numbers become null. Throws DecodeError naming the channel
/// and the byte count for a malformed message or an unknown channel.
Decoded decode(const std::string& channel, const void* data, std::size_t size);

/// The JSON schema of a JSON value, inferred from an example: objects with their properties (all
/// required), arrays with the type of their first item, integers, numbers, booleans and strings.
nlohmann::json schema_of(const nlohmann::json& example);

}  // namespace hpr::viewer
