#pragma once
/// \file
/// The cannelloni UDP format, version 2, and a CanTransport over it.
///
/// Datagram: version (u8 = 2), op code (u8, DATA = 0), sequence number (u8), frame count (u16),
/// then per frame: can_id (u32, SocketCAN flags included), length (u8; bit 7 set = CAN FD, then one
/// flags byte follows), the payload. Big-endian throughout. A remote bus is reached through a
/// cannelloni gateway; two processes on one machine use it to exercise the whole CAN path without
/// kernel CAN support.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "hpr/hal/can.hpp"

namespace hpr::hal {

inline constexpr std::uint8_t kCannelloniVersion = 2;
inline constexpr std::uint8_t kCannelloniOpData = 0;
inline constexpr std::size_t kCannelloniMaxDatagram = 1472;  ///< one Ethernet MTU of UDP payload

/// Encodes frames into one datagram; returns its size, or 0 if they do not fit in `out`.
std::size_t cannelloni_encode(std::span<const CanFrame> frames, std::uint8_t sequence, std::span<std::uint8_t> out);

/// Decodes a datagram, appending its frames to `out`. Returns an empty string, or what is wrong
/// (wrong version, truncated, length over 64); on error nothing is appended.
std::string cannelloni_decode(std::span<const std::uint8_t> datagram, std::vector<CanFrame>& out);

/// Address "host:port" for UDP; host may be a numeric IPv4 address or a name.
struct UdpEndpoint {
  std::string host;
  int port = 0;
  static UdpEndpoint parse(const std::string& text);  ///< throws std::invalid_argument with the text
};

/// A CAN bus carried over UDP in cannelloni format: binds `local`, sends to `remote`.
class UdpCannelloniTransport final : public CanTransport {
 public:
  UdpCannelloniTransport(std::string name, const UdpEndpoint& local, const UdpEndpoint& remote);
  ~UdpCannelloniTransport() override;
  UdpCannelloniTransport(const UdpCannelloniTransport&) = delete;
  UdpCannelloniTransport& operator=(const UdpCannelloniTransport&) = delete;
  bool send(const CanFrame& frame) override;
  void flush() override;
  int receive(std::vector<CanFrame>& out) override;
  [[nodiscard]] int fd() const override { return fd_; }
  [[nodiscard]] const BusCounters& counters() const override { return counters_; }
  void clear_bus_off() override { counters_.bus_off = false; }
  [[nodiscard]] std::string describe() const override;
  /// Datagrams that failed to decode.
  [[nodiscard]] std::int64_t malformed() const { return malformed_; }

 private:
  std::string name_, local_text_, remote_text_;
  int fd_ = -1;
  std::vector<std::uint8_t> remote_addr_;  // sockaddr_in bytes
  std::vector<CanFrame> queue_;
  std::vector<std::uint8_t> buffer_;
  std::uint8_t sequence_ = 0;
  BusCounters counters_;
  std::int64_t malformed_ = 0;
};

}  // namespace hpr::hal
