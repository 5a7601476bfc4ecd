#include "hpr/viewer/foxglove.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace hpr::viewer::foxglove {

using nlohmann::json;

std::string server_info(const std::string& name, const std::map<std::string, std::string>& metadata,
                        const std::string& session_id) {
  return json{{"op", "serverInfo"},
              {"name", name},
              {"capabilities", json::array()},
              {"supportedEncodings", json::array({"json"})},
              {"metadata", metadata},
              {"sessionId", session_id}}
      .dump();
}

std::string advertise(const std::vector<ChannelInfo>& list) {
  json chans = json::array();
  for (std::size_t i = 0; i < list.size(); ++i) {
    chans.push_back({{"id", i + 1},
                     {"topic", list[i].name},
                     {"encoding", "json"},
                     {"schemaName", list[i].schema_name},
                     {"schema", list[i].schema.dump()},
                     {"schemaEncoding", "jsonschema"}});
  }
  return json{{"op", "advertise"}, {"channels", chans}}.dump();
}

std::string status(Level level, const std::string& message) {
  return json{{"op", "status"}, {"level", static_cast<int>(level)}, {"message", message}}.dump();
}

std::string message_data(std::uint32_t subscription_id, std::uint64_t timestamp_ns, std::string_view payload) {
  std::string out(13 + payload.size(), '\0');
  out[0] = static_cast<char>(kOpMessageData);
  for (int b = 0; b < 4; ++b) out[static_cast<std::size_t>(1 + b)] = static_cast<char>((subscription_id >> (8 * b)) & 0xffU);
  for (int b = 0; b < 8; ++b) out[static_cast<std::size_t>(5 + b)] = static_cast<char>((timestamp_ns >> (8 * b)) & 0xffU);
  std::copy(payload.begin(), payload.end(), out.begin() + 13);
  return out;
}

bool parse_message_data(std::string_view frame, MessageData& out) {
  if (frame.size() < 13 || static_cast<std::uint8_t>(frame[0]) != kOpMessageData) return false;
  auto byte = [&](std::size_t i) { return static_cast<std::uint64_t>(static_cast<std::uint8_t>(frame[i])); };
  out.subscription_id = 0;
  for (std::size_t b = 0; b < 4; ++b) out.subscription_id |= static_cast<std::uint32_t>(byte(1 + b) << (8 * b));
  out.timestamp_ns = 0;
  for (std::size_t b = 0; b < 8; ++b) out.timestamp_ns |= byte(5 + b) << (8 * b);
  out.payload.assign(frame.substr(13));
  return true;
}

std::string Subscriptions::apply(std::string_view text, std::size_t num_channels) {
  const json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return "not a JSON object";
  const auto op = j.find("op");
  if (op == j.end() || !op->is_string()) return "no \"op\"";
  std::string errors;
  auto note = [&errors](const std::string& e) { errors += (errors.empty() ? "" : "; ") + e; };
  if (*op == "subscribe") {
    const auto subs = j.find("subscriptions");
    if (subs == j.end() || !subs->is_array()) return "subscribe: no \"subscriptions\" array";
    for (const auto& s : *subs) {
      if (!s.is_object() || !s.contains("id") || !s.contains("channelId") || !s["id"].is_number_unsigned() ||
          !s["channelId"].is_number_unsigned()) {
        note("subscribe: an item without unsigned \"id\" and \"channelId\"");
        continue;
      }
      const auto id = s["id"].get<std::uint64_t>();
      const auto ch = s["channelId"].get<std::uint64_t>();
      if (id > 0xffffffffULL) {
        note(fmt::format("subscribe: id {} does not fit 32 bits", id));
      } else if (ch == 0 || ch > num_channels) {
        note(fmt::format("subscribe: unknown channel id {}", ch));
      } else if (by_id_.count(static_cast<std::uint32_t>(id)) != 0) {
        note(fmt::format("subscribe: subscription id {} is already in use", id));
      } else {
        by_id_[static_cast<std::uint32_t>(id)] = static_cast<std::uint32_t>(ch);
      }
    }
    return errors;
  }
  if (*op == "unsubscribe") {
    const auto ids = j.find("subscriptionIds");
    if (ids == j.end() || !ids->is_array()) return "unsubscribe: no \"subscriptionIds\" array";
    for (const auto& id : *ids) {
      if (!id.is_number_unsigned() || id.get<std::uint64_t>() > 0xffffffffULL ||
          by_id_.erase(static_cast<std::uint32_t>(id.get<std::uint64_t>())) == 0) {
        note(fmt::format("unsubscribe: {} is not a subscription", id.dump()));
      }
    }
    return errors;
  }
  return fmt::format("operation {} is not supported", op->dump());
}

std::vector<std::uint32_t> Subscriptions::of_channel(std::uint32_t channel_id) const {
  std::vector<std::uint32_t> ids;
  for (const auto& [id, ch] : by_id_) {
    if (ch == channel_id) ids.push_back(id);
  }
  return ids;
}

}  // namespace hpr::viewer::foxglove
