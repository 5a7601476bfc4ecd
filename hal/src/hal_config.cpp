/// \file
/// The hal's configuration: buses, drives (MIT mode or CiA 402), safety, and the transports it opens.
#include "hpr/hal/hal.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <map>
#include <optional>
#include <set>

#include "hpr/hal/cannelloni.hpp"
#include "hpr/hal/socketcan.hpp"

namespace hpr::hal {

namespace {

/// The buses (`buses`), with the top level's transport defaults: `transport`, and for udp the
/// hosts and a base port (bus b: hal at base + 2b, the drives' side at base + 2b + 1) unless a bus
/// gives `local` and `remote`. Each bus's index by name.
std::map<std::string, int> load_buses(const Config& c, std::vector<BusConfig>& buses) {
  std::map<std::string, int> bus_index;
  const std::string transport = c.choice_or("transport", "udp", {"socketcan", "udp"});
  const std::string protocol = c.choice_or("protocol", "mit", {"mit", "cia402"});
  const std::string hal_host = c.string_or("udp_hal_host", "127.0.0.1");
  const std::string drive_host = c.string_or("udp_drive_host", "127.0.0.1");
  const long base_port = c.integer_or("udp_base_port", 21000, 1024, 65000);
  for (const Config& b : c.items("buses")) {
    BusConfig bc;
    bc.name = b.string("name");
    bc.transport = b.choice_or("transport", transport, {"socketcan", "udp"});
    bc.fd = b.boolean_or("fd", false);
    bc.bitrate = b.real_or("bitrate", bc.bitrate, 1e4, 1e6);
    bc.data_bitrate = bc.fd ? b.real_or("data_bitrate", bc.data_bitrate, bc.bitrate, 1.6e7) : bc.bitrate;
    bc.protocol = b.choice_or("protocol", protocol, {"mit", "cia402"}) == "cia402" ? DriveProtocol::kCia402 : DriveProtocol::kMit;
    if (bc.transport == "socketcan") {
      bc.interface = b.string_or("interface", bc.name);
    } else {
      const long port = base_port + 2 * static_cast<long>(buses.size());
      bc.local = b.string_or("local", hal_host + ":" + std::to_string(port));
      bc.remote = b.string_or("remote", drive_host + ":" + std::to_string(port + 1));
      for (const auto* e : {&bc.local, &bc.remote}) {
        try {
          (void)UdpEndpoint::parse(*e);
        } catch (const std::exception& ex) {
          throw ConfigError(b.file() + ": " + b.full_key(e == &bc.local ? "local" : "remote") + ": " + ex.what());
        }
      }
    }
    if (!bus_index.emplace(bc.name, static_cast<int>(buses.size())).second) {
      throw ConfigError(b.file() + ": " + b.full_key("name") + ": bus '" + bc.name + "' is defined twice");
    }
    buses.push_back(bc);
  }
  if (buses.empty()) throw ConfigError(c.file() + ": " + c.full_key("buses") + ": no bus configured");
  return bus_index;
}

/// The index of the bus named by `where`'s `key`.
int bus_of(const Config& where, const std::string& key, const std::map<std::string, int>& bus_index) {
  const std::string name = where.string(key);
  const auto it = bus_index.find(name);
  if (it == bus_index.end()) throw ConfigError(where.file() + ": " + where.full_key(key) + ": unknown bus '" + name + "'");
  return it->second;
}

/// The CANopen master's times (`hal.canopen`).
CanOpenTiming load_canopen_timing(const Config& co) {
  CanOpenTiming t;
  t.heartbeat_ms = static_cast<int>(co.integer_or("heartbeat_ms", t.heartbeat_ms, 1, 10000));
  t.heartbeat_timeout = co.real_or("heartbeat_timeout", 5e-3 * t.heartbeat_ms, 1e-3, 60.0);
  if (t.heartbeat_timeout <= 1e-3 * t.heartbeat_ms) {
    co.fail("heartbeat_timeout", "must be longer than the producer time heartbeat_ms (" + std::to_string(t.heartbeat_ms) + " ms)");
  }
  t.sdo_timeout = co.real_or("sdo_timeout", t.sdo_timeout, 1e-3, 10.0);
  t.boot_timeout = co.real_or("boot_timeout", t.boot_timeout, 1e-2, 60.0);
  t.enable_timeout = co.real_or("enable_timeout", t.enable_timeout, 1e-3, 10.0);
  return t;
}

/// A CiA 402 drive's units, from the keys of `c` (hal.canopen, or a drive's `cia402` block) over `s`.
void load_scaling(const Config& c, Cia402Scaling& s) {
  s.counts_per_revolution = c.real_or("counts_per_revolution", s.counts_per_revolution, 1.0, 1e12);
  s.gear_ratio = c.real_or("gear_ratio", s.gear_ratio, 1e-3, 1e5);
  if (c.has("velocity_unit")) s.velocity_rpm = c.choice("velocity_unit", {"increments_per_second", "rpm"}) == "rpm";
  s.rated_torque = c.real_or("rated_torque", s.rated_torque, 1e-6, 1e5);
}

/// The drive's EDS: the objects cyclic synchronous torque needs, mappable where a PDO carries them,
/// and the mode supported; its rated torque (0x6076) unless the configuration gives one (true when
/// the EDS gave it).
bool apply_eds(const std::string& path, const Config& where, bool rated_given, DriveConfig& dc) {
  using namespace canopen;
  ObjectDictionary od;
  try {
    od = ObjectDictionary::load(path);
  } catch (const ConfigError& e) {
    throw ConfigError(where.file() + ": " + where.full_key("eds") + ": " + e.what());
  }
  const struct {
    std::uint16_t index;
    bool mapped;
    const char* why;
  } needed[] = {{kControlword, true, "RPDO1 carries the controlword"},   {kStatusword, true, "TPDO1 carries the statusword"},
                {kTargetTorque, true, "RPDO1 carries the target torque"}, {kTorqueActual, true, "TPDO1 carries the torque actual value"},
                {kPositionActual, true, "TPDO1 carries the position"},    {kVelocityActual, true, "TPDO2 carries the velocity"},
                {kModesOfOperation, false, "the hal sets cyclic synchronous torque"},
                {0x1017, false, "the hal sets the heartbeat producer time"}};
  for (const auto& n : needed) {
    const OdEntry& e = od.require(n.index, 0, n.why);
    if (n.mapped && !e.pdo_mappable) {
      throw ConfigError(fmt::format("{}:{}: [{:04X}] PDOMapping = 0: {} ({}) must be mappable: {} (from {})", path, e.line, n.index, e.name,
                                    fmt::format("0x{:04X}", n.index), n.why, where.full_key("eds")));
    }
  }
  if (const auto modes = od.value(kSupportedModes, 0, dc.id); modes && (*modes & (1U << 9)) == 0) {
    const OdEntry& e = *od.find(kSupportedModes, 0);
    throw ConfigError(fmt::format("{}:{}: [6502] DefaultValue = 0x{:08X}: the drive does not support cyclic synchronous torque (bit 9)", path,
                                  e.line, *modes));
  }
  if (!rated_given) {
    if (const auto rated = od.value(kRatedTorque, 0, dc.id); rated && *rated > 0) {
      dc.cia402.rated_torque = static_cast<double>(*rated) * 1e-3;
      return true;
    }
  }
  return false;
}

/// Identifiers the sensor devices use (docs/CAN.md) that a CiA 402 node's TPDO1 would take.
bool collides_with_sensors(int node) { return node == 1 || node == 2 || (node >= 0x10 && node <= 0x13); }

}  // namespace

HalConfig HalConfig::load(const Config& c, const model::RobotSpec& robot) {
  const model::Model& m = robot.model;
  c.reject_unknown({"period", "reply_window", "transport", "udp_hal_host", "udp_drive_host", "udp_base_port", "enable_on_start",
                    "duration", "damping_kd", "soft_limit_margin", "soft_limit_kd", "safety", "drive_defaults", "sensors", "buses",
                    "drives", "clock", "lockstep_timeout", "held_joints", "protocol", "canopen"});
  HalConfig h;
  h.file = c.file();
  h.period = c.real_or("period", h.period, 1e-4, 0.1);
  h.reply_window = c.real_or("reply_window", h.reply_window, 0.0, h.period);
  h.lockstep = c.choice_or("clock", "realtime", {"realtime", "lockstep"}) == "lockstep";
  h.lockstep_timeout = c.real_or("lockstep_timeout", h.lockstep_timeout, 1e-3, 60.0);
  h.damping_kd = c.real_or("damping_kd", h.damping_kd, 0.0, 1e4);
  h.soft_limit_margin = c.real_or("soft_limit_margin", h.soft_limit_margin, 0.0, 1.0);
  h.soft_limit_kd = c.real_or("soft_limit_kd", h.soft_limit_kd, 0.0, 1e4);
  if (c.has("held_joints")) {
    const Config hj = c.section("held_joints");
    hj.reject_unknown({"kp", "kd"});
    h.held_kp = hj.real_or("kp", h.held_kp, 0.0, 1e5);
    h.held_kd = hj.real_or("kd", h.held_kd, 0.0, 1e4);
  }
  if (c.has("safety")) {
    const Config s = c.section("safety");
    s.reject_unknown({"command_max_age", "torque_off_after", "missed_replies_fault"});
    h.safety.command_max_age = s.real_or("command_max_age", h.safety.command_max_age, 1e-4, 1.0);
    h.safety.torque_off_after = s.real_or("torque_off_after", h.safety.torque_off_after, 0.0, 60.0);
    h.safety.missed_replies_fault = static_cast<int>(s.integer_or("missed_replies_fault", h.safety.missed_replies_fault, 1, 1000));
  }
  std::optional<Config> canopen;
  if (c.has("canopen")) {
    canopen = c.section("canopen");
    canopen->reject_unknown({"heartbeat_ms", "heartbeat_timeout", "sdo_timeout", "boot_timeout", "enable_timeout", "counts_per_revolution",
                             "gear_ratio", "velocity_unit", "rated_torque", "eds"});
    h.canopen = load_canopen_timing(*canopen);
  }
  const std::map<std::string, int> bus_index = load_buses(c, h.buses);
  if (c.has("sensors")) h.sensor_bus = bus_of(c.section("sensors"), "bus", bus_index);

  h.controlled = m.nj;
  std::set<std::pair<int, int>> ids;
  h.drives = drive::read_drives<DriveConfig>(c, robot, [&](const Config& d, DriveConfig& dc) {
    dc.bus = bus_of(d, "bus", bus_index);
    dc.id = static_cast<int>(d.integer("id", 1, MitCodec::kMaxDriveId));
    const DriveProtocol bus_protocol = h.buses[static_cast<std::size_t>(dc.bus)].protocol;
    dc.protocol = d.has("protocol") ? (d.choice("protocol", {"mit", "cia402"}) == "cia402" ? DriveProtocol::kCia402 : DriveProtocol::kMit)
                                    : bus_protocol;
    if (dc.protocol == DriveProtocol::kCia402) {
      bool rated_given = false;
      if (canopen) {
        load_scaling(*canopen, dc.cia402);
        rated_given = canopen->has("rated_torque");
        if (canopen->has("eds")) dc.eds = canopen->file_path("eds");
      }
      std::optional<Config> own;
      if (d.has("cia402")) {
        own = d.section("cia402");
        own->reject_unknown({"counts_per_revolution", "gear_ratio", "velocity_unit", "rated_torque"});
        rated_given = rated_given || own->has("rated_torque");
      }
      if (d.has("eds")) dc.eds = d.file_path("eds");
      if (!dc.eds.empty()) rated_given = apply_eds(dc.eds, d.has("eds") ? d : *canopen, rated_given, dc) || rated_given;
      if (own) load_scaling(*own, dc.cia402);
      dc.cia402.rated_torque_given = rated_given;
      if (dc.bus == h.sensor_bus && collides_with_sensors(dc.id)) {
        throw ConfigError(d.file() + ": " + d.full_key("id") + ": CiA 402 node " + std::to_string(dc.id) +
                          " on the sensor bus: its TPDO1 would use an identifier of the IMU or F/T frames (nodes 1, 2, 16-19 are taken there)");
      }
    } else {
      for (const char* key : {"cia402", "eds"}) {
        if (d.has(key)) d.fail(key, "is for a CiA 402 drive; this drive speaks MIT mode (set protocol: cia402 on it or its bus)");
      }
    }
    if (!ids.emplace(dc.bus, dc.id).second) {
      throw ConfigError(d.file() + ": " + d.full_key("id") + ": drive id " + std::to_string(dc.id) + " is used twice on bus '" +
                        h.buses[static_cast<std::size_t>(dc.bus)].name + "'");
    }
  });
  return h;
}

std::vector<std::unique_ptr<CanTransport>> open_buses(const HalConfig& c, bool emulator_side) {
  std::vector<std::unique_ptr<CanTransport>> out;
  for (std::size_t b = 0; b < c.buses.size(); ++b) {
    const BusConfig& bc = c.buses[b];
    if (bc.transport == "udp") {
      const auto local = UdpEndpoint::parse(emulator_side ? bc.remote : bc.local);
      const auto remote = UdpEndpoint::parse(emulator_side ? bc.local : bc.remote);
      out.push_back(std::make_unique<UdpCannelloniTransport>(bc.name, local, remote));
      continue;
    }
    // Receive filters: the hal hears replies and sensor frames, a drive emulator hears commands and SYNC.
    std::vector<SocketCanFilter> filters;
    bool canopen_bus = false;
    for (const auto& d : c.drives) {
      if (d.bus != static_cast<int>(b)) continue;
      const auto node = static_cast<std::uint32_t>(d.id);
      if (d.protocol == DriveProtocol::kCia402) {
        // The drive's side hears RPDO1 and SDO requests (and NMT, SYNC below); the hal hears the
        // TPDOs, SDO answers, EMCY and heartbeat.
        canopen_bus = true;
        const std::initializer_list<std::uint32_t> ids =
            emulator_side ? std::initializer_list<std::uint32_t>{canopen::kRpdo1, canopen::kSdoRxBase}
                          : std::initializer_list<std::uint32_t>{canopen::kTpdo1, canopen::kTpdo2, canopen::kSdoTxBase, canopen::kEmcyBase,
                                                                 canopen::kHeartbeatBase};
        for (const std::uint32_t base : ids) filters.push_back({base + node, kCanSffMask});
        continue;
      }
      filters.push_back({emulator_side ? node : MitCodec::kReplyBase + node, kCanSffMask});
    }
    if (canopen_bus && emulator_side) {
      filters.push_back({canopen::kNmtId, kCanSffMask});
      if (c.sensor_bus != static_cast<int>(b)) filters.push_back({canopen::kSyncId, kCanSffMask});
    }
    if (c.sensor_bus == static_cast<int>(b)) {
      if (emulator_side) {
        filters.push_back({kSyncId, kCanSffMask});
      } else {
        filters.push_back({0x180, 0x7F0});  // IMU 0x180-0x18F
        filters.push_back({0x190, 0x7F0});  // F/T 0x190-0x19F
      }
    }
    if (c.lockstep && !emulator_side) filters.push_back({kLockstepTickId, kCanSffMask});
    out.push_back(std::make_unique<SocketCanTransport>(bc.interface, bc.fd, filters));
  }
  return out;
}

}  // namespace hpr::hal
