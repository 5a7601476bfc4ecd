#pragma once
/// \file
/// A CanTransport on a raw SocketCAN socket (PF_CAN, CAN_RAW): CAN FD frames when configured,
/// receive filters for the identifiers the bus expects, error frames enabled and decoded,
/// non-blocking I/O. What it sends is what `candump` shows on the same interface.
#include <string>
#include <vector>

#include "hpr/hal/can.hpp"

namespace hpr::hal {

struct SocketCanFilter {
  std::uint32_t id = 0, mask = kCanSffMask;
};

class SocketCanTransport final : public CanTransport {
 public:
  /// Opens `interface` (throws std::runtime_error naming the interface and the reason, for
  /// example a kernel without CAN support: "Address family not supported").
  SocketCanTransport(std::string interface, bool fd_frames, const std::vector<SocketCanFilter>& filters);
  ~SocketCanTransport() override;
  SocketCanTransport(const SocketCanTransport&) = delete;
  SocketCanTransport& operator=(const SocketCanTransport&) = delete;
  bool send(const CanFrame& frame) override;
  void flush() override {}
  int receive(std::vector<CanFrame>& out) override;
  [[nodiscard]] int fd() const override { return fd_; }
  [[nodiscard]] const BusCounters& counters() const override { return counters_; }
  void clear_bus_off() override { counters_.bus_off = false; }
  [[nodiscard]] std::string describe() const override { return "socketcan:" + interface_; }

 private:
  std::string interface_;
  bool fd_frames_;
  int fd_ = -1;
  BusCounters counters_;
};

}  // namespace hpr::hal
