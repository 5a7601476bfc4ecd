#pragma once
/// \file Opening LCM with a clear failure: the URL comes from the command line, the configuration
/// or LCM_DEFAULT_URL; before LCM is created the multicast route is checked so that a missing
/// loopback route gives one message with the command that fixes it.

#include <memory>
#include <stdexcept>
#include <string>

namespace lcm {
class LCM;
}

namespace hpr::node {

/// LCM could not be opened. what() says why and how to fix it.
class LcmError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The default multicast URL of LCM.
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

/// First non-empty of: `explicit_url`, `configured_url`, $LCM_DEFAULT_URL, kDefaultLcmUrl.
std::string resolve_lcm_url(const std::string& explicit_url, const std::string& configured_url);

/// The command (as root) that sets up loopback multicast for LCM.
inline constexpr const char* kMulticastFixCommand =
    "sudo ip link set lo multicast on && sudo ip route add 239.0.0.0/8 dev lo";

/// Checks that a udpm URL's multicast group is routable. Throws LcmError with the fix otherwise.
/// Non-udpm URLs (memq://, file://) are accepted as they are.
void check_multicast_route(const std::string& url);

/// The socket receive buffer a subscriber asks for [bytes]: ~0.25 s of the whole stack at 1 kHz, so
/// that a process the scheduler holds up for a moment loses no message (the kernel caps it at
/// net.core.rmem_max, which tools/install-deps raises to 64 MB).
inline constexpr int kReceiveBufferBytes = 4 << 20;
/// The socket receive buffer of a process that reads LCM's socket on its own loop [bytes]: it is
/// read only between the process's steps, where liblcm's receive thread reads it whenever it gets
/// a core, so it holds a loaded machine's pause of the whole stack running in lockstep (about
/// 0.3 s at 3 000 ticks/s).
inline constexpr int kDirectReceiveBufferBytes = 32 << 20;
/// The socket receive buffer of a recorder [bytes]: seconds of the whole stack's traffic.
inline constexpr int kRecorderBufferBytes = 64 << 20;

/// The subscription queue of a listener that must see every message (a recorder, a test, an
/// evaluation) [messages]. LCM's default of 30 drops messages when the listener is held up for a
/// few milliseconds; a control node keeps the default (it wants the latest message, not a backlog).
inline constexpr int kCountingQueueCapacity = 100000;

/// A udpm URL with `recv_buf_size=bytes` added unless it sets one; other URLs unchanged.
std::string with_receive_buffer(const std::string& url, int bytes = kReceiveBufferBytes);

/// check_multicast_route, then creates the LCM instance (with_receive_buffer applied); throws
/// LcmError on any failure.
std::unique_ptr<lcm::LCM> open_lcm(const std::string& url);

}  // namespace hpr::node
