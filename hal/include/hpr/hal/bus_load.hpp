#pragma once
/// \file
/// How long a bus is busy each tick: the frames of a configuration's drives and sensors at the
/// bus's bit rates, nominally and with worst-case bit stuffing (ISO 11898-1 frame formats, 11-bit
/// identifiers). The hal says it at start and warns when a bus cannot carry its tick.
#include <string>

#include "hpr/hal/hal.hpp"

namespace hpr::hal {

/// One data frame's time on the wire [s]: `payload` bytes, classic or CAN FD (bit-rate switch to
/// `data_bitrate` when it is higher), from start of frame to the end of the interframe space.
struct FrameTime {
  double nominal = 0.0;     ///< without stuff bits
  double worst_case = 0.0;  ///< with the most stuff bits the frame's content can cause
};
FrameTime frame_time(int payload, bool fd, double bitrate, double data_bitrate);

/// What one tick puts on a bus: every frame both ways (MIT mode: command and reply; CiA 402:
/// RPDO1, TPDO1, TPDO2 and its heartbeat averaged over the producer time), one SYNC where the bus
/// has sensors or CiA 402 drives, the sensor frames.
struct BusLoad {
  double frames = 0.0;      ///< per tick (a heartbeat counts as its fraction)
  FrameTime busy;           ///< [s] per tick
  [[nodiscard]] double worst_share(double period) const { return busy.worst_case / period; }
};
BusLoad tick_load(const HalConfig& c, int bus);

/// One line for the log: drives per protocol, busy time per tick against the period, e.g.
/// "can0 (1 Mbit/s): 3 CiA 402 drives, 807 us nominal / 976 us worst case of a 1000 us tick".
std::string describe_load(const HalConfig& c, int bus);

}  // namespace hpr::hal
