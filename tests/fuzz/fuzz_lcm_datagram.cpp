// Fuzz target: what a node reads off LCM's multicast socket (hpr/node/udpm.hpp). The input is a
// sequence of datagrams, each [sender byte][length, 2 bytes][bytes], fed to one reader as they
// would arrive from up to 256 senders. A refusal always has a reason; a message delivered has a
// channel of 1 to 63 bytes without NUL and a payload of at most kMaxMessageBytes; the reader
// never reads outside a datagram (AddressSanitizer).
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "hpr/node/udpm.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using hpr::node::LcmDatagrams;
  LcmDatagrams reader;
  const hpr::node::MessageSink sink = [](std::string_view channel, const std::uint8_t* payload, std::size_t n, std::int64_t) {
    if (channel.empty() || channel.size() > LcmDatagrams::kMaxChannelLength) std::abort();
    if (channel.find('\0') != std::string_view::npos) std::abort();
    if (n > LcmDatagrams::kMaxMessageBytes) std::abort();
    if (n > 0 && payload == nullptr) std::abort();
    volatile std::uint8_t sum = 0;
    for (std::size_t i = 0; i < n; ++i) sum = static_cast<std::uint8_t>(sum + payload[i]);  // every byte readable
  };
  std::size_t at = 0;
  while (at + 3 <= size) {
    const std::uint64_t sender = data[at];
    const std::size_t len = std::min<std::size_t>((std::size_t{data[at + 1]} << 8) | data[at + 2], size - at - 3);
    at += 3;
    // Its own copy, so that reading past the datagram is caught.
    auto* datagram = static_cast<std::uint8_t*>(std::malloc(len == 0 ? 1 : len));
    if (len > 0) std::memcpy(datagram, data + at, len);
    const std::string why = reader.feed(datagram, len, sender, 0, sink);
    std::free(datagram);
    (void)why;
    at += len;
  }
  return 0;
}
