#pragma once
/// \file
/// What a process publishes: the encoding of a message with the process's identity (`source`, on the
/// clocked types) and the deployment's authentication code (on the signed types), and the typed
/// output that does both (docs/SAFETY.md, "Who may command the robot" and "Sources").

#include <lcm/lcm-cpp.hpp>

#include <atomic>
#include <concepts>
#include <memory>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "hpr/common/auth.hpp"

namespace hpr::node {

/// An lcm-gen type whose third field is `int64_t source` (bytes 24-31): the publisher's identity in
/// its upper 32 bits (random, drawn at the process's start; 0: unstamped, a tool's or a test's
/// message) and in its lower 32 bits the publisher's message counter, which goes up by one with
/// every message the process publishes (docs/SAFETY.md, "Replayed messages").
template <class Msg>
concept Sourced = requires(const Msg& m) {
  { m.source } -> std::convertible_to<std::int64_t>;
} && std::is_same_v<decltype(Msg::source), std::int64_t>;

template <class Msg>
std::int64_t source_of(const Msg& m) {
  if constexpr (Sourced<Msg>) {
    return m.source;
  } else {
    return 0;
  }
}

/// The encoded offset of a Sourced type's `source`: after the 8-byte fingerprint, `tick` and `utime`.
inline constexpr int kSourceOffset = 24;

/// Encodes `m` into `buffer` (grown as needed); a Sourced type is stamped with `source` (0: as the
/// message holds it), then a signed type with a key gets its authentication code for `channel` (the
/// full name it is published on). Returns the encoded size (negative: not encodable).
template <class Msg>
int encode_message(const Msg& m, std::vector<std::uint8_t>& buffer, std::string_view channel, const auth::Key* key,
                   std::int64_t source = 0) {
  const int n = m.getEncodedSize();
  if (buffer.size() < static_cast<std::size_t>(n)) buffer.resize(static_cast<std::size_t>(n));
  const int used = m.encode(buffer.data(), 0, n);
  if constexpr (Sourced<Msg>) {
    if (used >= kSourceOffset + 8 && source != 0) {
      const auto u = static_cast<std::uint64_t>(source);
      for (int b = 0; b < 8; ++b) buffer[static_cast<std::size_t>(kSourceOffset + b)] = static_cast<std::uint8_t>(u >> (56 - 8 * b));
    }
  }
  if constexpr (auth::Signed<Msg>) {
    if (used > 0 && key != nullptr) auth::sign(buffer.data(), static_cast<std::size_t>(used), channel, *key);
  }
  return used;
}

/// Publishes `m` on `channel` signed with `key` (a tool's or a test's publication of a signed type).
template <class Msg>
void publish_signed(lcm::LCM& lcm, const std::string& channel, const Msg& m, const auth::Key& key) {
  std::vector<std::uint8_t> buffer;
  const int used = encode_message(m, buffer, channel, &key);
  if (used >= 0) lcm.publish(channel, buffer.data(), static_cast<unsigned>(used));
}

/// The identity part of a `source` (its upper 32 bits) and its counter (the lower 32).
inline std::uint32_t source_identity(std::int64_t source) { return static_cast<std::uint32_t>(static_cast<std::uint64_t>(source) >> 32); }
inline std::uint32_t source_counter(std::int64_t source) { return static_cast<std::uint32_t>(static_cast<std::uint64_t>(source)); }
/// A process's message counter, shared by its outputs: every message it publishes gets the next.
using SourceCounter = std::shared_ptr<std::atomic<std::uint32_t>>;

/// A typed output; encodes into a buffer reused across calls, stamped with the process's `source`
/// and its next message count (a Sourced type) and signed with `key` (a signed type).
template <class Msg>
class Output {
 public:
  Output() = default;
  Output(lcm::LCM* lcm, std::string channel, const auth::Key* key = nullptr, std::int64_t source = 0, SourceCounter counter = {})
      : lcm_(lcm), channel_(std::move(channel)), key_(key), source_(source), counter_(std::move(counter)) {}
  void publish(const Msg& m) {
    std::int64_t source = source_;
    if constexpr (Sourced<Msg>) {
      if (source != 0 && counter_) source = static_cast<std::int64_t>(static_cast<std::uint64_t>(source) | (counter_->fetch_add(1) + 1U));
    }
    const int used = encode_message(m, buffer_, channel_, key_, source);
    if (used >= 0) lcm_->publish(channel_, buffer_.data(), static_cast<unsigned>(used));
  }
  [[nodiscard]] const std::string& channel() const { return channel_; }

 private:
  lcm::LCM* lcm_ = nullptr;
  std::string channel_;
  const auth::Key* key_ = nullptr;
  std::int64_t source_ = 0;
  SourceCounter counter_;
  std::vector<std::uint8_t> buffer_;
};

}  // namespace hpr::node
