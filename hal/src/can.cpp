#include "hpr/hal/can.hpp"

namespace hpr::hal {

std::uint8_t fd_length(std::uint8_t len) {
  static constexpr std::uint8_t kSizes[] = {8, 12, 16, 20, 24, 32, 48, 64};
  if (len <= 8) return len;
  for (const auto s : kSizes) {
    if (len <= s) return s;
  }
  return 64;
}

bool account_error_frame(const CanFrame& frame, BusCounters& counters) {
  if ((frame.id & kCanErrFlag) == 0) return false;
  ++counters.errors;
  const std::uint32_t cls = frame.id & ~kCanErrFlag;
  if ((cls & kCanErrBusOff) != 0) {
    counters.bus_off = true;
    counters.last_error = "bus-off";
  } else if ((cls & kCanErrRestarted) != 0) {
    counters.last_error = "controller restarted";
  } else if ((cls & kCanErrCrtl) != 0) {
    counters.last_error = "controller problem (data[1] = " + std::to_string(frame.data[1]) + ")";
  } else {
    counters.last_error = "error frame class " + std::to_string(cls);
  }
  return true;
}

}  // namespace hpr::hal
