#include "hpr/hal/bus_load.hpp"

#include <fmt/format.h>

#include <cmath>

namespace hpr::hal {

FrameTime frame_time(int payload, bool fd, double bitrate, double data_bitrate) {
  FrameTime t;
  if (!fd) {
    // SOF, identifier 11, RTR, IDE, r0, DLC 4, data, CRC 15: 34 + 8n bits that are stuffed; CRC
    // delimiter, ACK slot and delimiter, EOF 7, interframe space 3: 13 more.
    const int n = payload;
    const int stuffed = 34 + 8 * n;
    t.nominal = (stuffed + 13) / bitrate;
    t.worst_case = (stuffed + 13 + (stuffed - 1) / 4) / bitrate;
    return t;
  }
  // CAN FD: SOF, identifier 11, RRS, IDE, FDF, res, BRS at the nominal rate; ESI, DLC 4, data,
  // stuff count 4 and CRC 17 (21 above 16 bytes) with its fixed stuff bits, CRC delimiter at the
  // data rate; ACK slot and delimiter, EOF 7, interframe space 3 at the nominal rate again.
  const int n = fd_length(static_cast<std::uint8_t>(payload));
  const int crc = n > 16 ? 21 : 17;
  const int fixed_stuff = (4 + crc + 3) / 4;
  const int arbitration = 17, tail = 12;
  const int data = 1 + 4 + 8 * n + 4 + crc + fixed_stuff + 1;
  const int dynamic_arbitration = (arbitration - 1) / 4, dynamic_data = (5 + 8 * n - 1) / 4;
  t.nominal = (arbitration + tail) / bitrate + data / data_bitrate;
  t.worst_case = (arbitration + dynamic_arbitration + tail) / bitrate + (data + dynamic_data) / data_bitrate;
  return t;
}

BusLoad tick_load(const HalConfig& c, int bus) {
  const BusConfig& b = c.buses[static_cast<std::size_t>(bus)];
  BusLoad load;
  auto add = [&](int payload, double count) {
    const FrameTime f = frame_time(payload, b.fd, b.bitrate, b.data_bitrate);
    load.frames += count;
    load.busy.nominal += count * f.nominal;
    load.busy.worst_case += count * f.worst_case;
  };
  bool sync = bus == c.sensor_bus;
  for (const DriveConfig& d : c.drives) {
    if (d.bus != bus) continue;
    if (d.protocol == DriveProtocol::kCia402) {
      add(4, 1.0);  // RPDO1: controlword, target torque
      add(8, 1.0);  // TPDO1: statusword, torque, position
      add(4, 1.0);  // TPDO2: velocity
      add(1, c.period / (1e-3 * c.canopen.heartbeat_ms));
      sync = true;
    } else {
      add(8, 2.0);  // command and reply
    }
  }
  if (sync) add(0, 1.0);
  if (bus == c.sensor_bus) add(8, 7.0);  // IMU 3, F/T 2 × 2
  return load;
}

std::string describe_load(const HalConfig& c, int bus) {
  const BusConfig& b = c.buses[static_cast<std::size_t>(bus)];
  int mit = 0, cia402 = 0;
  for (const DriveConfig& d : c.drives) {
    if (d.bus == bus) ++(d.protocol == DriveProtocol::kCia402 ? cia402 : mit);
  }
  const BusLoad l = tick_load(c, bus);
  std::string what;
  if (mit > 0) what += fmt::format("{} MIT-mode drive{}", mit, mit == 1 ? "" : "s");
  if (cia402 > 0) what += fmt::format("{}{} CiA 402 drive{}", what.empty() ? "" : ", ", cia402, cia402 == 1 ? "" : "s");
  if (bus == c.sensor_bus) what += std::string(what.empty() ? "" : ", ") + "the sensors";
  if (what.empty()) what = "nothing";
  const std::string rate = b.fd ? fmt::format("CAN FD {:g}/{:g} Mbit/s", b.bitrate * 1e-6, b.data_bitrate * 1e-6)
                                : fmt::format("{:g} Mbit/s", b.bitrate * 1e-6);
  return fmt::format("{} ({}): {}, {:.0f} us nominal / {:.0f} us worst case of a {:.0f} us tick", b.name, rate, what,
                     l.busy.nominal * 1e6, l.busy.worst_case * 1e6, c.period * 1e6);
}

}  // namespace hpr::hal
