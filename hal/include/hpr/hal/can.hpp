#pragma once
/// \file
/// CAN frames and the transport interface (SocketCAN or cannelloni over UDP) the hal and the drive
/// emulator share. Nothing here knows the drive protocol.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace hpr::hal {

/// One classic CAN or CAN FD frame. `id` carries SocketCAN's flag bits (CAN_EFF_FLAG, CAN_ERR_FLAG).
struct CanFrame {
  std::uint32_t id = 0;
  std::uint8_t len = 0;    ///< payload bytes (≤ 8 classic, ≤ 64 FD)
  bool fd = false;
  std::uint8_t flags = 0;  ///< CAN FD flags (BRS, ESI)
  std::array<std::uint8_t, 64> data{};
};

/// SocketCAN's identifier flag bits and the error-frame classes we decode (linux/can.h, can/error.h).
inline constexpr std::uint32_t kCanEffFlag = 0x80000000U;
inline constexpr std::uint32_t kCanRtrFlag = 0x40000000U;
inline constexpr std::uint32_t kCanErrFlag = 0x20000000U;
inline constexpr std::uint32_t kCanSffMask = 0x000007FFU;
inline constexpr std::uint32_t kCanErrBusOff = 0x00000040U;
inline constexpr std::uint32_t kCanErrCrtl = 0x00000004U;
inline constexpr std::uint32_t kCanErrRestarted = 0x00000100U;

/// Valid CAN FD payload lengths round up to 0..8, 12, 16, 20, 24, 32, 48, 64.
std::uint8_t fd_length(std::uint8_t len);

/// What a transport counts.
struct BusCounters {
  std::int64_t tx_frames = 0, rx_frames = 0, errors = 0, dropped = 0;
  std::int64_t foreign = 0;  ///< datagrams refused for coming from another address than the bus's peer (UDP)
  bool bus_off = false;
  std::string last_error;
};

/// One CAN bus. Non-blocking: send queues, flush writes what the tick queued, receive returns what
/// has arrived. Error frames are decoded into the counters and bus-off state, never returned.
class CanTransport {
 public:
  virtual ~CanTransport() = default;
  /// Queues a frame (false when the transport refused it; counted).
  virtual bool send(const CanFrame& frame) = 0;
  /// Writes every queued frame (one datagram per call for UDP).
  virtual void flush() = 0;
  /// Appends the frames that have arrived to `out`; returns how many.
  virtual int receive(std::vector<CanFrame>& out) = 0;
  /// File descriptor to poll for input.
  [[nodiscard]] virtual int fd() const = 0;
  [[nodiscard]] virtual const BusCounters& counters() const = 0;
  /// Clears a latched bus-off (after the controller restarted).
  virtual void clear_bus_off() = 0;
  [[nodiscard]] virtual std::string describe() const = 0;
};

/// Handles an error frame (CAN_ERR_FLAG set) for a transport's counters. Returns true if it was one.
bool account_error_frame(const CanFrame& frame, BusCounters& counters);

}  // namespace hpr::hal
