#pragma once
/// \file
/// The Foxglove WebSocket protocol (subprotocol `foxglove.websocket.v1`), server side, JSON message
/// encoding: the text operations a server sends (serverInfo, advertise, status), the client
/// operations it accepts (subscribe, unsubscribe), and the binary message-data frame.
/// Specification: https://github.com/foxglove/ws-protocol/blob/main/docs/spec.md

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "hpr/viewer/channels.hpp"

namespace hpr::viewer::foxglove {

inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";
inline constexpr std::uint8_t kOpMessageData = 0x01;

/// serverInfo: the server's name, no optional capabilities, JSON encoding, `metadata` as strings.
std::string server_info(const std::string& name, const std::map<std::string, std::string>& metadata,
                        const std::string& session_id);
/// advertise: every channel of `list`, channel id = index + 1, JSON encoding, JSON schema.
std::string advertise(const std::vector<ChannelInfo>& list);
enum class Level { kInfo = 0, kWarning = 1, kError = 2 };
std::string status(Level level, const std::string& message);

/// Binary message data: opcode 0x01, subscription id (u32 LE), timestamp [ns] (u64 LE), payload.
std::string message_data(std::uint32_t subscription_id, std::uint64_t timestamp_ns, std::string_view payload);
struct MessageData {
  std::uint32_t subscription_id = 0;
  std::uint64_t timestamp_ns = 0;
  std::string payload;
};
/// Parses a binary frame; false when it is not message data (wrong opcode or too short).
bool parse_message_data(std::string_view frame, MessageData& out);

/// One client's subscriptions: subscription id -> channel id, as the client chose them.
class Subscriptions {
 public:
  /// Applies one text operation from the client. Returns an empty string when it was applied,
  /// else what was wrong (for a status message): malformed JSON, an unknown operation, an unknown
  /// channel id, a subscription id already in use or not in use. A partly valid operation applies
  /// its valid parts.
  std::string apply(std::string_view text, std::size_t num_channels);
  /// The subscription ids of `channel_id` (one client may subscribe twice).
  [[nodiscard]] std::vector<std::uint32_t> of_channel(std::uint32_t channel_id) const;
  [[nodiscard]] std::size_t size() const { return by_id_.size(); }

 private:
  std::map<std::uint32_t, std::uint32_t> by_id_;
};

}  // namespace hpr::viewer::foxglove
