// The hal's CiA 402 master against a CiA 402 device, frame by frame: the start-up a drive sees
// (NMT, SDO configuration read back from the drive's objects, NMT start), the state machine up to
// Operation enabled, the units of the process data, and the supervision (EMCY, heartbeat, a
// restarted drive, a refused SDO write, a fault reset on request).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "hpr/hal/bus_load.hpp"
#include "hpr/hal/cia402.hpp"

namespace {

using namespace hpr::hal;
using namespace hpr::hal::canopen;

/// One master and one device joined frame by frame, 1 ms per tick: the master's frames and a SYNC,
/// the device's answers, the device's periodic frames, the master's supervision.
struct Link {
  ObjectDictionary od;
  Cia402Device device;
  Cia402Master master;
  double now = 0.0;
  bool device_answers = true;
  std::vector<CanFrame> wire;  ///< every frame, in order (a candump of the bus)

  explicit Link(std::string eds = Cia402Device::default_eds(500), Cia402Scaling scaling = {}, CanOpenTiming timing = {})
      : od(ObjectDictionary::parse(eds, "drive.eds")), device(5, od), master(5, scaling, timing) {
    std::vector<CanFrame> out;
    device.power_on(out);
    deliver(out);
  }
  void deliver(const std::vector<CanFrame>& frames) {
    for (const CanFrame& f : frames) {
      wire.push_back(f);
      master.on_frame(f, now);
    }
  }
  void tick(bool enable = false, double torque = 0.0) {
    now += 1e-3;
    std::vector<CanFrame> to_drive, from_drive;
    master.tick(now, enable, torque, to_drive);
    to_drive.push_back(sync_frame());
    for (const CanFrame& f : to_drive) {
      wire.push_back(f);
      if (device_answers) device.on_frame(f, now, from_drive);
    }
    if (device_answers) device.periodic(now, 0.02, from_drive);
    deliver(from_drive);
    master.supervise(now);
  }
  /// Ticks until the master runs cyclically (or `limit` ticks).
  int start(int limit = 500) {
    int k = 0;
    while (!master.cyclic() && master.phase() != Cia402Master::Phase::kFailed && k < limit) {
      tick();
      ++k;
    }
    return k;
  }
};

TEST(Cia402Master, StartsADriveTheWayCia301AndCia402Ask) {
  Link l;
  const int ticks = l.start();
  ASSERT_TRUE(l.master.cyclic()) << l.master.fault_text();
  EXPECT_LT(ticks, 100);
  // The order on the bus: NMT reset communication, the drive's boot-up, the SDO reads and writes
  // each answered before the next, NMT start, then an operational heartbeat.
  ASSERT_GE(l.wire.size(), 4u);
  std::vector<const CanFrame*> bus;
  for (const CanFrame& f : l.wire) {
    if (f.id != canopen::kSyncId) bus.push_back(&f);
  }
  EXPECT_EQ(bus[0]->id, kHeartbeatBase + 5) << "the boot-up at power-on";
  EXPECT_EQ(bus[1]->id, kNmtId);
  EXPECT_EQ(bus[1]->data[0], static_cast<std::uint8_t>(NmtCommand::kResetCommunication));
  EXPECT_EQ(bus[1]->data[1], 5);
  EXPECT_EQ(bus[2]->id, kHeartbeatBase + 5);
  EXPECT_EQ(bus[2]->data[0], 0) << "boot-up after the reset";
  // What the drive is: device type, supported modes, rated torque, each read and answered.
  std::size_t k = 3;
  for (const std::uint16_t index : {kDeviceType, kSupportedModes, kRatedTorque}) {
    ASSERT_LT(k + 1, bus.size());
    const auto req = decode_sdo(*bus[k], 5), answer = decode_sdo(*bus[k + 1], 5);
    ASSERT_TRUE(req.has_value() && answer.has_value());
    EXPECT_EQ(req->kind, SdoMessage::Kind::kUploadRequest);
    EXPECT_EQ(req->address.index, index);
    EXPECT_EQ(answer->kind, SdoMessage::Kind::kUploadData);
    k += 2;
  }
  const auto writes = cst_configuration(5, CanOpenTiming{}.heartbeat_ms);
  for (const SdoWrite& w : writes) {
    ASSERT_LT(k + 1, bus.size());
    const auto req = decode_sdo(*bus[k], 5);
    ASSERT_TRUE(req.has_value());
    EXPECT_EQ(req->kind, SdoMessage::Kind::kDownloadRequest);
    EXPECT_EQ(req->address.index, w.address.index);
    EXPECT_EQ(bus[k + 1]->id, kSdoTxBase + 5) << "each write answered before the next: " << w.what;
    k += 2;
    while (k < bus.size() && bus[k]->id == kHeartbeatBase + 5) ++k;  // pre-operational heartbeats once 0x1017 is set
  }
  ASSERT_LT(k, bus.size());
  EXPECT_EQ(bus[k]->id, kNmtId);
  EXPECT_EQ(bus[k]->data[0], static_cast<std::uint8_t>(NmtCommand::kStart));
  // What the drive holds afterwards, read from its own objects.
  EXPECT_EQ(l.device.object(kModesOfOperation, 0), 10u);
  EXPECT_EQ(l.device.object(0x1600, 0), 2u);
  EXPECT_EQ(l.device.object(0x1600, 1), 0x60400010u);
  EXPECT_EQ(l.device.object(0x1600, 2), 0x60710010u);
  EXPECT_EQ(l.device.object(0x1A00, 3), 0x60640020u);
  EXPECT_EQ(l.device.object(0x1A01, 1), 0x606C0020u);
  EXPECT_EQ(l.device.object(0x1800, 1), 0x185u) << "TPDO1 enabled on its COB-ID";
  EXPECT_EQ(l.device.object(0x1017, 0), static_cast<std::uint64_t>(CanOpenTiming{}.heartbeat_ms));
  EXPECT_EQ(l.device.nmt(), NmtState::kOperational);
  EXPECT_EQ(l.master.fault_code(), 0);
}

TEST(Cia402Master, EnablesThroughTheStateMachineAndSendsTorqueInThousandthsOfRated) {
  Cia402Scaling s;
  s.counts_per_revolution = 4096;
  s.gear_ratio = 50;
  s.rated_torque = 0.5;  // 25 N m at the joint: 0.025 N m per thousandth
  Link l(Cia402Device::default_eds(500), s);
  l.start();
  ASSERT_TRUE(l.master.cyclic()) << l.master.fault_text();
  l.tick();
  EXPECT_EQ(l.device.drive().state(), canopen::DriveState::kSwitchOnDisabled);
  int k = 0;
  while (!l.master.enabled() && k < 20) {
    l.tick(true, 3.0);
    ++k;
  }
  ASSERT_TRUE(l.master.enabled());
  EXPECT_LE(k, 5) << "shutdown, switch on, enable operation: a round trip each";
  EXPECT_EQ(l.device.target_torque(), 0) << "no torque before the drive reports Operation enabled";
  l.tick(true, 3.0);
  EXPECT_EQ(l.device.target_torque(), 120) << "3 N m / (0.5 N m x 50 / 1000)";
  l.tick(true, -1e9);
  EXPECT_EQ(l.device.target_torque(), -32767) << "saturated";
  l.tick(true, std::nan(""));
  EXPECT_EQ(l.device.target_torque(), 0) << "never a non-finite number on the wire";
  // Units of the samples: one motor revolution is 4096 increments, 50 of them one joint turn.
  l.device.set_actual(4096 * 25, 4096, -40);
  l.tick(true, 0.0);
  EXPECT_NEAR(l.master.position(), std::numbers::pi, 1e-12);
  EXPECT_NEAR(l.master.velocity(), 2.0 * std::numbers::pi / 50.0, 1e-12);
  EXPECT_NEAR(l.master.torque(), -1.0, 1e-12);
  EXPECT_TRUE(l.master.replied());
  // Torque off: back to Switch on disabled.
  l.tick(false, 3.0);
  l.tick(false, 3.0);
  EXPECT_EQ(l.device.drive().state(), canopen::DriveState::kSwitchOnDisabled);
  EXPECT_EQ(l.device.target_torque(), 0);
  EXPECT_EQ(l.master.fault_code(), 0) << l.master.fault_text();
}

TEST(Cia402Master, AnEmergencyIsLatchedWithItsMeaningAndResetOnlyOnRequest) {
  Link l;
  l.start();
  for (int k = 0; k < 10; ++k) l.tick(true, 0.0);
  ASSERT_TRUE(l.master.enabled());
  std::vector<CanFrame> out;
  l.device.fault(0x2310, out);
  l.deliver(out);
  for (int k = 0; k < 5; ++k) l.tick(true, 1.0);
  EXPECT_EQ(l.master.fault_code(), 0x2310);
  EXPECT_NE(l.master.fault_text().find("EMCY 0x2310"), std::string::npos) << l.master.fault_text();
  EXPECT_NE(l.master.fault_text().find("current"), std::string::npos) << l.master.fault_text();
  EXPECT_EQ(l.device.drive().state(), canopen::DriveState::kFault);
  EXPECT_EQ(l.device.target_torque(), 0);
  for (int k = 0; k < 50; ++k) l.tick(true, 1.0);
  EXPECT_EQ(l.device.drive().state(), canopen::DriveState::kFault) << "no reset without a request";
  EXPECT_EQ(l.master.fault_code(), 0x2310);
  l.master.reset_fault();
  for (int k = 0; k < 10; ++k) l.tick(false, 0.0);
  EXPECT_EQ(l.device.drive().state(), canopen::DriveState::kSwitchOnDisabled) << "reset by the rising edge of bit 7";
  EXPECT_EQ(l.master.fault_code(), 0) << l.master.fault_text();
  for (int k = 0; k < 10; ++k) l.tick(true, 0.0);
  EXPECT_TRUE(l.master.enabled());
}

TEST(Cia402Master, ASilentDriveARestartedDriveAndAnUnaskedStateChangeAreFaults) {
  {
    Link l;
    l.start();
    for (int k = 0; k < 10; ++k) l.tick(true, 0.0);
    l.device_answers = false;
    int k = 0;
    while (l.master.fault_code() == 0 && k < 1000) {
      l.tick(true, 0.0);
      ++k;
    }
    EXPECT_EQ(l.master.fault_code(), Cia402Master::kFaultHeartbeat);
    EXPECT_NEAR(k * 1e-3, CanOpenTiming{}.heartbeat_timeout, CanOpenTiming{}.heartbeat_ms * 1e-3 + 2e-3) << l.master.fault_text();
    EXPECT_FALSE(l.master.replied());
  }
  {
    Link l;
    l.start();
    for (int k = 0; k < 10; ++k) l.tick(true, 0.0);
    std::vector<CanFrame> out;
    l.device.on_frame(nmt(NmtCommand::kResetNode, 5), l.now, out);
    l.deliver(out);
    EXPECT_EQ(l.master.fault_code(), Cia402Master::kFaultRestarted) << l.master.fault_text();
    EXPECT_EQ(l.master.phase(), Cia402Master::Phase::kFailed);
    l.master.reset_fault();
    EXPECT_LT(l.start(), 200);
    EXPECT_TRUE(l.master.cyclic()) << "a reset request starts the drive again: " << l.master.fault_text();
  }
  {
    Link l;
    l.start();
    for (int k = 0; k < 10; ++k) l.tick(true, 0.0);
    // The drive is told (by someone else) to go to pre-operational: its PDOs stop.
    std::vector<CanFrame> out;
    l.device.on_frame(nmt(NmtCommand::kPreOperational, 0), l.now, out);
    for (int k = 0; k < 30; ++k) l.tick(true, 0.0);
    EXPECT_EQ(l.master.fault_code(), Cia402Master::kFaultNmtState) << l.master.fault_text();
  }
}

TEST(Cia402Master, ARefusedConfigurationNamesTheObjectAndTheAbortCode) {
  // A drive whose target torque cannot be mapped into a PDO.
  std::string eds = Cia402Device::default_eds(500);
  const auto at = eds.find("[6071]");
  ASSERT_NE(at, std::string::npos);
  eds.replace(eds.find("PDOMapping=1", at), 12, "PDOMapping=0");
  Link l(eds);
  l.start();
  EXPECT_EQ(l.master.phase(), Cia402Master::Phase::kFailed);
  EXPECT_EQ(l.master.fault_code(), Cia402Master::kFaultStartUp);
  const std::string& e = l.master.fault_text();
  EXPECT_NE(e.find("0x1600:02"), std::string::npos) << e;
  EXPECT_NE(e.find("target torque"), std::string::npos) << e;
  EXPECT_NE(e.find("0x06040041"), std::string::npos) << e;
  EXPECT_NE(e.find("cannot be mapped"), std::string::npos) << e;
  // A drive that never boots.
  Link silent;
  silent.device_answers = false;
  CanOpenTiming t;
  silent.start(static_cast<int>(t.boot_timeout * 1e3) + 10);
  EXPECT_EQ(silent.master.phase(), Cia402Master::Phase::kFailed);
  EXPECT_NE(silent.master.fault_text().find("no boot-up message"), std::string::npos) << silent.master.fault_text();
}

TEST(Cia402Master, ReadsWhatTheDriveIsBeforeConfiguringIt) {
  // The rated torque scales every torque: the drive's own 0x6076 is taken when the configuration
  // gives none, and a disagreement with the configuration stops the start-up.
  Cia402Scaling unset;
  Link adopt(Cia402Device::default_eds(1200), unset);
  adopt.start();
  ASSERT_TRUE(adopt.master.cyclic()) << adopt.master.fault_text();
  EXPECT_DOUBLE_EQ(adopt.master.scaling().rated_torque, 1.2);
  Cia402Scaling given;
  given.rated_torque = 0.5;
  given.rated_torque_given = true;
  Link mismatch(Cia402Device::default_eds(1200), given);
  mismatch.start();
  EXPECT_EQ(mismatch.master.phase(), Cia402Master::Phase::kFailed);
  EXPECT_NE(mismatch.master.fault_text().find("0x6076 = 1200 mN m disagrees with the configuration's 0.5 N m"), std::string::npos)
      << mismatch.master.fault_text();
  // Not a drive: another device profile.
  std::string eds = Cia402Device::default_eds(500);
  eds.replace(eds.find("0x00020192"), 10, "0x00000191");
  Link io(eds);
  io.start();
  EXPECT_EQ(io.master.phase(), Cia402Master::Phase::kFailed);
  EXPECT_NE(io.master.fault_text().find("profile 401, not a CiA 402 drive"), std::string::npos) << io.master.fault_text();
  // A drive without cyclic synchronous torque.
  eds = Cia402Device::default_eds(500);
  eds.replace(eds.find("0x00000280"), 10, "0x00000080");
  Link csp(eds);
  csp.start();
  EXPECT_NE(csp.master.fault_text().find("no cyclic synchronous torque (bit 9)"), std::string::npos) << csp.master.fault_text();
}

TEST(Cia402Device, AnswersOnlyWhatItsMappingSaysAndRejectsAWrongLengthRpdo) {
  Link l;
  l.start();
  l.tick();
  std::vector<CanFrame> out;
  CanFrame rpdo;
  rpdo.id = kRpdo1 + 5;
  rpdo.len = 3;
  l.device.on_frame(rpdo, l.now, out);
  ASSERT_EQ(out.size(), 1u);
  const auto e = decode_emergency(out[0], 5);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->code, 0x8210) << "PDO not processed due to length error";
  // TPDO1 is 8 bytes (statusword, torque, position), TPDO2 4 (velocity).
  out.clear();
  l.device.on_frame(sync_frame(), l.now, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].id, kTpdo1 + 5);
  EXPECT_EQ(out[0].len, 8);
  EXPECT_EQ(out[1].id, kTpdo2 + 5);
  EXPECT_EQ(out[1].len, 4);
  const std::uint16_t sw = static_cast<std::uint16_t>(out[0].data[0] | (out[0].data[1] << 8));
  EXPECT_EQ(decode_statusword(sw), canopen::DriveState::kSwitchOnDisabled);
}

// Cyclic synchronous position (mode 8): the target position (0x607A) taken at the SYNC after an
// RPDO, while Operation enabled in that mode only; in torque mode the torque alone.
TEST(Cia402Device, TakesTheTargetPositionAtTheSyncInCyclicSynchronousPositionOnly) {
  Link l;
  l.start();
  for (int k = 0; k < 20 && !l.device.drive().enabled(); ++k) l.tick(true);
  ASSERT_TRUE(l.device.drive().enabled());
  EXPECT_FALSE(l.device.target_position().has_value()) << "cyclic synchronous torque";
  std::vector<CanFrame> out;
  l.device.on_frame(sdo_download(5, {kTargetPosition, 0}, static_cast<std::uint32_t>(-12345), 4), l.now, out);
  l.device.on_frame(sdo_download(5, {kModesOfOperation, 0}, static_cast<std::uint32_t>(kModeCyclicSyncPosition), 1), l.now, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].data[0], 0x60) << "download confirmed";
  EXPECT_EQ(out[1].data[0], 0x60) << "download confirmed";
  EXPECT_NE(l.device.target_position().value_or(0), -12345) << "not before the SYNC";
  l.tick(true, 1.0);
  ASSERT_TRUE(l.device.target_position().has_value());
  EXPECT_EQ(*l.device.target_position(), -12345);
  EXPECT_EQ(l.device.target_torque(), 0) << "no torque set-point in position mode";
  EXPECT_EQ(l.device.object(kModesOfOperationDisplay, 0).value_or(0), static_cast<std::uint64_t>(kModeCyclicSyncPosition));
  l.device.on_frame(sdo_download(5, {kModesOfOperation, 0}, static_cast<std::uint32_t>(kModeCyclicSyncTorque), 1), l.now, out);
  l.tick(true);
  EXPECT_FALSE(l.device.target_position().has_value());
}

// Frame times against the classic worst-case formula of CAN schedulability analysis (Davis et al.,
// 2007: (55 + 10 n) bit times for an 11-bit identifier and n data bytes) and the nominal frame
// (47 + 8 n); CAN FD by its properties.
TEST(BusLoad, FrameTimesAndTheTickOfACia402Bus) {
  for (int n = 0; n <= 8; ++n) {
    const FrameTime t = frame_time(n, false, 1e6, 1e6);
    EXPECT_NEAR(t.nominal, (47 + 8 * n) * 1e-6, 1e-12) << n;
    EXPECT_NEAR(t.worst_case, (55 + 10 * n) * 1e-6, 1e-12) << n;
  }
  const FrameTime fd_slow = frame_time(8, true, 1e6, 1e6), fd_fast = frame_time(8, true, 1e6, 5e6), classic = frame_time(8, false, 1e6, 1e6);
  EXPECT_GT(fd_slow.nominal, classic.nominal) << "an FD frame without a faster data phase carries a longer CRC";
  EXPECT_LT(fd_fast.nominal, 0.5 * classic.nominal);
  EXPECT_DOUBLE_EQ(frame_time(9, true, 1e6, 5e6).nominal, frame_time(12, true, 1e6, 5e6).nominal) << "9 bytes travel in an FD frame of 12";
  EXPECT_GT(frame_time(12, true, 1e6, 5e6).nominal, fd_fast.nominal);
  // A bus of 3 CiA 402 drives at 1 kHz, 1 Mbit/s: RPDO1 (4 bytes), TPDO1 (8), TPDO2 (4) each, one
  // SYNC, a heartbeat per drive every 20 ms.
  HalConfig c;
  c.buses.push_back(BusConfig{});
  c.buses[0].name = "can0";
  for (int k = 1; k <= 3; ++k) {
    DriveConfig d;
    d.bus = 0;
    d.id = k;
    d.protocol = DriveProtocol::kCia402;
    c.drives.push_back(d);
  }
  const BusLoad l = tick_load(c, 0);
  const double nominal = 3 * (79 + 111 + 79 + 55.0 / 20) + 47, worst = 3 * (95 + 135 + 95 + 65.0 / 20) + 55;
  EXPECT_NEAR(l.busy.nominal * 1e6, nominal, 1e-6);
  EXPECT_NEAR(l.busy.worst_case * 1e6, worst, 1e-6);
  EXPECT_GT(l.worst_share(1e-3), 0.95) << "three CiA 402 drives fill a classic 1 Mbit/s bus at 1 kHz";
  EXPECT_NE(describe_load(c, 0).find("3 CiA 402 drives"), std::string::npos) << describe_load(c, 0);
}

}  // namespace
