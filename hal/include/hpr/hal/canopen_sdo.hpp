#pragma once
/// \file
/// Configuring a CiA 402 drive over SDO: the writes that map its process data and set its mode
/// (cyclic synchronous torque), a client that sends them one at a time and says which one a drive
/// refused and why, and a server over a drive's object dictionary (the emulator's side, and the
/// tests' drive). Time is the caller's: nothing here sleeps or reads a clock.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "hpr/hal/canopen.hpp"
#include "hpr/hal/eds.hpp"

namespace hpr::hal::canopen {

/// One expedited SDO download and what it is for (said when the drive refuses it).
struct SdoWrite {
  SdoAddress address;
  std::uint32_t value = 0;
  int size = 4;  ///< bytes
  std::string what;
};

/// The process data of cyclic synchronous torque (0x6060 = 10), each PDO synchronous (transmission
/// type 1: every SYNC):
///   RPDO1 (0x200 + node): controlword 0x6040 (16 bits), target torque 0x6071 (16);
///   TPDO1 (0x180 + node): statusword 0x6041 (16), torque actual 0x6077 (16), position actual 0x6064 (32);
///   TPDO2 (0x280 + node): velocity actual 0x606C (32).
/// Each PDO is disabled (COB-ID bit 31), its mapping cleared, written and counted, then enabled, as
/// CiA 301 §7.5.2.35 asks; then the mode of operation and the heartbeat producer time (0x1017, ms).
std::vector<SdoWrite> cst_configuration(int node, int heartbeat_ms);

/// The SDO client: the writes in order, each sent once the previous one is confirmed.
class SdoSequence {
 public:
  SdoSequence(int node, std::vector<SdoWrite> writes, double timeout_s);
  /// The frame to send at time t [s], if one is due (the next write; none while one is pending).
  std::optional<CanFrame> poll(double t);
  /// A frame from the bus (other nodes' and other services' are ignored).
  void on_frame(const CanFrame& f, double t);
  [[nodiscard]] bool done() const { return next_ == writes_.size() && !failed(); }
  [[nodiscard]] bool failed() const { return !error_.empty(); }
  /// Why it stopped: the node, the object, the value, what it was for and the abort code's meaning
  /// (or that no answer came in time).
  [[nodiscard]] const std::string& error() const { return error_; }
  [[nodiscard]] std::size_t confirmed() const { return next_; }

 private:
  [[nodiscard]] std::string describe(const SdoWrite& w) const;
  int node_;
  std::vector<SdoWrite> writes_;
  double timeout_;
  std::size_t next_ = 0;
  std::optional<double> sent_at_;  ///< the pending write's time
  std::string error_;
};

/// The server side over a drive's object dictionary: reads and writes of the objects it holds,
/// refused with the abort code CiA 301 gives (no object, no sub-index, read-only, write-only,
/// length, an object that may not be mapped into a PDO).
class SdoServer {
 public:
  SdoServer(int node, const ObjectDictionary& od);
  /// The answer to a request to this node; nullopt for any other frame.
  std::optional<CanFrame> on_frame(const CanFrame& f);
  /// The value an object holds now.
  [[nodiscard]] std::optional<std::uint64_t> value(std::uint16_t index, std::uint8_t subindex) const;
  /// The device's own update of an object it holds (an actual value, the statusword).
  void set(std::uint16_t index, std::uint8_t subindex, std::uint64_t value) { values_[{index, subindex}] = value; }

 private:
  int node_;
  const ObjectDictionary* od_;
  std::map<std::pair<std::uint16_t, std::uint8_t>, std::uint64_t> values_;
};

}  // namespace hpr::hal::canopen
