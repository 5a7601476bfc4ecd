#pragma once
/// \file
/// The drive protocol: "MIT mode" impedance frames behind a codec interface (so that, for example,
/// CANopen CiA 402 can be added beside it).
///
/// Command (hal → drive), standard id = drive id, 8 bytes, big-endian bit fields:
///     p_des 16 | v_des 12 | kp 12 | kd 12 | τ_ff 12
/// each mapped linearly from [min, max] of the drive's limits onto the unsigned range (saturated).
/// Reply (drive → hal), standard id = kReplyBase + drive id, 8 bytes:
///     drive id 8 | p 16 | v 12 | τ 12 | fault code 8 | temperature 8 (°C + 40)
/// Special frames (0xFF × 7 then 0xFC / 0xFD / 0xFE): enter motor mode, exit motor mode, zero the
/// encoder at the present position. A drive answers every frame, special or not, with a reply.
#include <array>
#include <cstdint>
#include <optional>

#include "hpr/drive/drive.hpp"
#include "hpr/hal/can.hpp"

namespace hpr::hal {

/// Per-drive scaling: the ranges the 12- and 16-bit fields span (drive units: rad, rad/s, Nm).
using drive::DriveLimits;

/// One impedance command in drive units: τ = τ_ff + kp (p_des − p) + kd (v_des − v).
struct DriveCommand {
  double p_des = 0, v_des = 0, kp = 0, kd = 0, t_ff = 0;
};

/// One reply in drive units.
struct DriveReply {
  int drive_id = 0;
  double p = 0, v = 0, t = 0;
  std::uint8_t fault = 0;
  double temperature = 0;  ///< [°C]
};

enum class SpecialCommand : std::uint8_t { kEnterMotorMode = 0xFC, kExitMotorMode = 0xFD, kZeroEncoder = 0xFE };

/// Maps x ∈ [lo, hi] (saturated) onto an unsigned integer of `bits` bits, rounding to nearest.
std::uint32_t to_uint(double x, double lo, double hi, int bits);
/// The inverse of to_uint.
double from_uint(std::uint32_t u, double lo, double hi, int bits);

/// The wire format of one family of drives.
class DriveCodec {
 public:
  virtual ~DriveCodec() = default;
  [[nodiscard]] virtual CanFrame encode_command(int drive_id, const DriveCommand& c, const DriveLimits& l) const = 0;
  [[nodiscard]] virtual CanFrame encode_special(int drive_id, SpecialCommand s) const = 0;
  /// The reply's identifier for a drive (receive filters).
  [[nodiscard]] virtual std::uint32_t reply_id(int drive_id) const = 0;
  /// Decodes a reply; nullopt for a frame that is not a well-formed reply of this codec.
  [[nodiscard]] virtual std::optional<DriveReply> decode_reply(const CanFrame& f, const DriveLimits& l) const = 0;
  // Drive side (the emulator).
  [[nodiscard]] virtual CanFrame encode_reply(const DriveReply& r, const DriveLimits& l) const = 0;
  /// A decoded frame addressed to a drive: a command or a special frame.
  struct Request {
    int drive_id = 0;
    std::optional<DriveCommand> command;
    std::optional<SpecialCommand> special;
  };
  [[nodiscard]] virtual std::optional<Request> decode_request(const CanFrame& f, const DriveLimits& l) const = 0;
};

class MitCodec final : public DriveCodec {
 public:
  static constexpr std::uint32_t kReplyBase = 0x100;
  static constexpr int kMaxDriveId = 0x7F;
  [[nodiscard]] CanFrame encode_command(int drive_id, const DriveCommand& c, const DriveLimits& l) const override;
  [[nodiscard]] CanFrame encode_special(int drive_id, SpecialCommand s) const override;
  [[nodiscard]] std::uint32_t reply_id(int drive_id) const override { return kReplyBase + static_cast<std::uint32_t>(drive_id); }
  [[nodiscard]] std::optional<DriveReply> decode_reply(const CanFrame& f, const DriveLimits& l) const override;
  [[nodiscard]] CanFrame encode_reply(const DriveReply& r, const DriveLimits& l) const override;
  [[nodiscard]] std::optional<Request> decode_request(const CanFrame& f, const DriveLimits& l) const override;
};

// ---------------------------------------------------------------------------------------------
// Sensor devices on the bus (layouts in docs/CAN.md). The hal sends SYNC on each sensor bus every
// tick; each device answers with its frames, sampled at the same instant.
// ---------------------------------------------------------------------------------------------
inline constexpr std::uint32_t kSyncId = 0x080;
inline constexpr std::uint32_t kImuQuatId = 0x180;   ///< w, x, y, z: int16 × 1/32767
inline constexpr std::uint32_t kImuGyroId = 0x181;   ///< x, y, z: int16 × 1e-3 rad/s, then status u8
inline constexpr std::uint32_t kImuAccelId = 0x182;  ///< x, y, z: int16 × 1e-2 m/s², then status u8
inline constexpr std::uint32_t kFtForceId = 0x190;   ///< + 2 × sensor index: fx, fy, fz int16 × 0.1 N
inline constexpr std::uint32_t kFtTorqueId = 0x191;  ///< + 2 × sensor index: tx, ty, tz int16 × 0.01 Nm
inline constexpr double kImuGyroScale = 1e-3, kImuAccelScale = 1e-2, kFtForceScale = 0.1, kFtTorqueScale = 0.01;

// ---------------------------------------------------------------------------------------------
// The simulated clock (lockstep only; no real device sends it). A drive emulator in lockstep ends
// every tick it has answered with this frame on every bus, after its replies: the hal's tick is
// complete when each bus has delivered it, however long the emulator took.
// ---------------------------------------------------------------------------------------------
inline constexpr std::uint32_t kLockstepTickId = 0x7F0;  ///< emulator tick: int64, big-endian
CanFrame encode_lockstep_tick(std::int64_t tick);
/// The tick of a clock frame; nullopt if the frame is not 8 bytes.
std::optional<std::int64_t> decode_lockstep_tick(const CanFrame& f);

/// Three (or four) saturated int16 values, big-endian, in an 8-byte frame.
CanFrame encode_int16s(std::uint32_t id, const double* values, int count, double scale);
/// Decodes `count` int16 values; false if the frame is shorter than 2 × count bytes.
bool decode_int16s(const CanFrame& f, double* values, int count, double scale);

}  // namespace hpr::hal
