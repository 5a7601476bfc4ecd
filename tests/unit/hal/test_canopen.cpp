// CANopen frames and the CiA 402 state machine against the standards' own tables: the frames'
// bytes as CiA 301 lays them out (written here by hand, not produced by the encoder under test),
// the statusword patterns of IEC 61800-7-201 table 30 with the bits they leave free set either way,
// and the controlword transitions of table 31.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <initializer_list>

#include "hpr/hal/canopen.hpp"

namespace {

using namespace hpr::hal;
using namespace hpr::hal::canopen;

CanFrame raw(std::uint32_t id, std::initializer_list<int> bytes) {
  CanFrame f;
  f.id = id;
  f.len = static_cast<std::uint8_t>(bytes.size());
  size_t i = 0;
  for (int b : bytes) f.data[i++] = static_cast<std::uint8_t>(b);
  return f;
}

void expect_frame(const CanFrame& f, std::uint32_t id, std::initializer_list<int> bytes) {
  EXPECT_EQ(f.id, id);
  ASSERT_EQ(f.len, bytes.size());
  size_t i = 0;
  for (int b : bytes) EXPECT_EQ(f.data[i++], b) << "byte " << i - 1;
}

TEST(CanOpen, TheIdentifiersOfThePredefinedConnectionSet) {
  EXPECT_EQ(classify(raw(0x000, {1, 0})).function, Function::kNmt);
  EXPECT_EQ(classify(raw(0x080, {})).function, Function::kSync);
  const Cob emcy = classify(raw(0x085, {}));
  EXPECT_EQ(emcy.function, Function::kEmcy);
  EXPECT_EQ(emcy.node, 5);
  const Cob tpdo3 = classify(raw(0x3A0, {}));
  EXPECT_EQ(tpdo3.function, Function::kTpdo);
  EXPECT_EQ(tpdo3.pdo, 3);
  EXPECT_EQ(tpdo3.node, 0x20);
  const Cob rpdo4 = classify(raw(0x57F, {}));
  EXPECT_EQ(rpdo4.function, Function::kRpdo);
  EXPECT_EQ(rpdo4.pdo, 4);
  EXPECT_EQ(rpdo4.node, 127);
  EXPECT_EQ(classify(raw(0x5A1, {})).function, Function::kSdoTx);
  EXPECT_EQ(classify(raw(0x621, {})).function, Function::kSdoRx);
  EXPECT_EQ(classify(raw(0x701, {})).function, Function::kHeartbeat);
  EXPECT_EQ(classify(raw(0x780, {})).function, Function::kOther) << "node 0 is no node";
  EXPECT_EQ(classify(raw(0x701 | kCanEffFlag, {})).function, Function::kOther) << "an extended frame";
}

TEST(CanOpen, NmtSyncAndHeartbeatFrames) {
  expect_frame(nmt(NmtCommand::kStart, 3), 0x000, {0x01, 0x03});
  expect_frame(nmt(NmtCommand::kResetNode, 0), 0x000, {0x81, 0x00});
  expect_frame(nmt(NmtCommand::kPreOperational, 127), 0x000, {0x80, 0x7F});
  expect_frame(sync_frame(), 0x080, {});
  expect_frame(heartbeat(9, NmtState::kOperational), 0x709, {0x05});
  EXPECT_EQ(decode_heartbeat(raw(0x709, {0x7F}), 9), NmtState::kPreOperational);
  EXPECT_EQ(decode_heartbeat(raw(0x709, {0x00}), 9), NmtState::kBootUp);
  EXPECT_EQ(decode_heartbeat(raw(0x709, {0x85}), 9), NmtState::kOperational) << "node guarding's toggle bit";
  EXPECT_FALSE(decode_heartbeat(raw(0x709, {0x05}), 8)) << "another node's";
  EXPECT_FALSE(decode_heartbeat(raw(0x709, {0x06}), 9)) << "no such state";
  EXPECT_FALSE(decode_heartbeat(raw(0x709, {0x05, 0x00}), 9)) << "one byte";
}

TEST(CanOpen, ExpeditedSdoFramesAsCiA301LaysThemOut) {
  // Write 10 (cyclic synchronous torque) to 0x6060:00, one byte: 2F 60 60 00 0A 00 00 00.
  expect_frame(sdo_download(4, {0x6060, 0}, 10, 1), 0x604, {0x2F, 0x60, 0x60, 0x00, 0x0A, 0, 0, 0});
  // Write 0x1A000010 to 0x1A00:01, four bytes: 23 00 1A 01 10 00 00 1A.
  expect_frame(sdo_download(4, {0x1A00, 1}, 0x1A000010, 4), 0x604, {0x23, 0x00, 0x1A, 0x01, 0x10, 0x00, 0x00, 0x1A});
  expect_frame(sdo_download(4, {0x6040, 0}, 0x1234, 2), 0x604, {0x2B, 0x40, 0x60, 0x00, 0x34, 0x12, 0, 0});
  expect_frame(sdo_upload(4, {0x1000, 0}), 0x604, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});
  // The server's answers.
  const auto done = decode_sdo(raw(0x584, {0x60, 0x60, 0x60, 0x00, 0, 0, 0, 0}), 4);
  ASSERT_TRUE(done);
  EXPECT_EQ(done->kind, SdoMessage::Kind::kDownloadDone);
  EXPECT_EQ(done->address.index, 0x6060);
  // Device type 0x00020192 (CiA 402, servo drive) in four bytes: 43 00 10 00 92 01 02 00.
  const auto data = decode_sdo(raw(0x584, {0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00}), 4);
  ASSERT_TRUE(data);
  EXPECT_EQ(data->kind, SdoMessage::Kind::kUploadData);
  EXPECT_EQ(data->value, 0x00020192U);
  EXPECT_EQ(data->size, 4);
  // A two-byte statusword with junk in the unused bytes: 4B 41 60 00 37 06 AA AA.
  const auto sw = decode_sdo(raw(0x584, {0x4B, 0x41, 0x60, 0x00, 0x37, 0x06, 0xAA, 0xAA}), 4);
  ASSERT_TRUE(sw);
  EXPECT_EQ(sw->value, 0x0637U);
  EXPECT_EQ(sw->size, 2);
  // An abort: 80 60 60 00 30 00 09 06 = 0x06090030.
  const auto abort = decode_sdo(raw(0x584, {0x80, 0x60, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06}), 4);
  ASSERT_TRUE(abort);
  EXPECT_EQ(abort->kind, SdoMessage::Kind::kAbort);
  EXPECT_EQ(abort->value, 0x06090030U);
  EXPECT_STREQ(sdo_abort_meaning(abort->value), "invalid value for parameter (download only)");
  expect_frame(sdo_abort(4, {0x6060, 0}, 0x06090030), 0x584, {0x80, 0x60, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06});
  // The requests, as the device decodes them.
  const auto req = decode_sdo(sdo_download(4, {0x6060, 0}, 0xFFFFFF0A, 1), 4);
  ASSERT_TRUE(req);
  EXPECT_EQ(req->kind, SdoMessage::Kind::kDownloadRequest);
  EXPECT_EQ(req->value, 0x0AU) << "one byte";
  EXPECT_EQ(decode_sdo(sdo_upload(4, {0x1000, 0}), 4)->kind, SdoMessage::Kind::kUploadRequest);
  // What is not an expedited SDO of this node.
  EXPECT_FALSE(decode_sdo(raw(0x584, {0x41, 0x00, 0x10, 0x00, 8, 0, 0, 0}), 4)) << "segmented upload";
  EXPECT_FALSE(decode_sdo(raw(0x604, {0x21, 0x00, 0x10, 0x00, 8, 0, 0, 0}), 4)) << "segmented download";
  EXPECT_FALSE(decode_sdo(raw(0x585, {0x60, 0, 0, 0, 0, 0, 0, 0}), 4)) << "another node";
  EXPECT_FALSE(decode_sdo(raw(0x584, {0x60, 0, 0, 0}), 4)) << "short";
  EXPECT_FALSE(decode_sdo(raw(0x604, {0x60, 0, 0, 0, 0, 0, 0, 0}), 4)) << "a server's answer sent to the server";
}

TEST(CanOpen, EveryAbortCodeOfTheStandardHasItsMeaning) {
  for (std::uint32_t code : {0x05030000U, 0x05040000U, 0x05040001U, 0x05040002U, 0x05040003U, 0x05040004U, 0x05040005U,
                             0x06010000U, 0x06010001U, 0x06010002U, 0x06020000U, 0x06040041U, 0x06040042U, 0x06040043U,
                             0x06040047U, 0x06060000U, 0x06070010U, 0x06070012U, 0x06070013U, 0x06090011U, 0x06090030U,
                             0x06090031U, 0x06090032U, 0x06090036U, 0x060A0023U, 0x08000000U, 0x08000020U, 0x08000021U,
                             0x08000022U, 0x08000023U, 0x08000024U}) {
    EXPECT_STRNE(sdo_abort_meaning(code), "unknown abort code") << std::hex << code;
  }
  EXPECT_STREQ(sdo_abort_meaning(0x12345678), "unknown abort code");
  EXPECT_STREQ(sdo_abort_meaning(kAbortNoObject), "object does not exist in the object dictionary");
}

TEST(CanOpen, EmergencyFrames) {
  // Over-current on the output side (0x2310), error register bit 1 (current): 10 23 02 00 00 00 00 00.
  const auto e = decode_emergency(raw(0x087, {0x10, 0x23, 0x02, 0, 0, 0, 0, 0}), 7);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, 0x2310);
  EXPECT_EQ(e->error_register, 0x02);
  EXPECT_EQ(emergency_meaning(e->code), "current, device output side (0x2310)");
  EXPECT_EQ(emergency_meaning(0x8130), "communication: life guard or heartbeat error (0x8130)");
  EXPECT_EQ(emergency_meaning(0x4210), "device temperature (0x4210)");
  EXPECT_EQ(emergency_meaning(0x0000), "no error (error reset)");
  expect_frame(emergency(7, {0x2310, 0x02}), 0x087, {0x10, 0x23, 0x02, 0, 0, 0, 0, 0});
  EXPECT_FALSE(decode_emergency(raw(0x088, {0x10, 0x23, 0x02, 0, 0, 0, 0, 0}), 7));
  EXPECT_FALSE(decode_emergency(raw(0x087, {0x10, 0x23}), 7));
}

TEST(Cia402, TheStatuswordPatternsWhateverTheBitsTheyLeaveFree) {
  // (pattern, mask) of IEC 61800-7-201 table 30; every bit outside the mask set both ways.
  struct Row {
    std::uint16_t value, mask;
    canopen::DriveState state;
  };
  const std::array<Row, 8> rows{{{0x0000, 0x004F, canopen::DriveState::kNotReadyToSwitchOn},
                                 {0x0040, 0x004F, canopen::DriveState::kSwitchOnDisabled},
                                 {0x0021, 0x006F, canopen::DriveState::kReadyToSwitchOn},
                                 {0x0023, 0x006F, canopen::DriveState::kSwitchedOn},
                                 {0x0027, 0x006F, canopen::DriveState::kOperationEnabled},
                                 {0x0007, 0x006F, canopen::DriveState::kQuickStopActive},
                                 {0x000F, 0x004F, canopen::DriveState::kFaultReactionActive},
                                 {0x0008, 0x004F, canopen::DriveState::kFault}}};
  for (const Row& r : rows) {
    for (std::uint32_t free = 0; free <= 0xFFFF; free += 0x0111) {
      const auto sw = static_cast<std::uint16_t>(r.value | (free & ~r.mask & 0xFFFF));
      const auto s = decode_statusword(sw);
      ASSERT_TRUE(s) << std::hex << sw;
      EXPECT_EQ(*s, r.state) << std::hex << sw;
    }
  }
  EXPECT_FALSE(decode_statusword(0x0001)) << "ready-to-switch-on's bit alone, quick stop clear: no state";
  EXPECT_FALSE(decode_statusword(0x0003));
}

TEST(Cia402, TheDeviceFollowsTable31AndReportsItsStateInItsStatusword) {
  DriveStateMachine d;
  EXPECT_EQ(d.state(), canopen::DriveState::kNotReadyToSwitchOn);
  EXPECT_EQ(d.apply(kCwShutdown), 0) << "nothing before start-up";
  d.tick();
  EXPECT_EQ(d.state(), canopen::DriveState::kSwitchOnDisabled);
  EXPECT_EQ(d.apply(kCwSwitchOn), 0) << "switch on from switch on disabled is no transition";
  EXPECT_EQ(d.apply(kCwShutdown), 2);
  EXPECT_EQ(d.apply(kCwSwitchOn), 3);
  EXPECT_EQ(d.apply(kCwEnableOperation), 4);
  EXPECT_TRUE(d.enabled());
  EXPECT_EQ(d.apply(kCwDisableOperation), 5);
  EXPECT_EQ(d.apply(kCwShutdown), 6);
  EXPECT_EQ(d.apply(kCwQuickStop), 7);
  EXPECT_EQ(d.state(), canopen::DriveState::kSwitchOnDisabled);
  for (int t : {2, 3, 4}) EXPECT_EQ(d.apply(t == 2 ? kCwShutdown : t == 3 ? kCwSwitchOn : kCwEnableOperation), t);
  EXPECT_EQ(d.apply(kCwShutdown), 8);
  (void)d.apply(kCwSwitchOn);
  (void)d.apply(kCwEnableOperation);
  EXPECT_EQ(d.apply(kCwDisableVoltage), 9);
  (void)d.apply(kCwShutdown);
  (void)d.apply(kCwSwitchOn);
  EXPECT_EQ(d.apply(kCwDisableVoltage), 10);
  (void)d.apply(kCwShutdown);
  (void)d.apply(kCwSwitchOn);
  (void)d.apply(kCwEnableOperation);
  EXPECT_EQ(d.apply(kCwQuickStop), 11);
  EXPECT_FALSE(d.enabled());
  EXPECT_EQ(d.apply(kCwEnableOperation), 16);
  (void)d.apply(kCwQuickStop);
  EXPECT_EQ(d.apply(kCwDisableVoltage), 12);
  // A fault from operation enabled: reaction, then fault; reset on bit 7's rising edge only.
  (void)d.apply(kCwShutdown);
  (void)d.apply(kCwSwitchOn);
  (void)d.apply(kCwEnableOperation);
  d.fault();
  EXPECT_EQ(d.state(), canopen::DriveState::kFaultReactionActive);
  EXPECT_FALSE(d.enabled());
  d.tick();
  EXPECT_EQ(d.state(), canopen::DriveState::kFault);
  EXPECT_EQ(d.apply(kCwEnableOperation), 0) << "a fault is left only by a reset";
  EXPECT_EQ(d.apply(kCwFaultReset), 15);
  EXPECT_EQ(d.state(), canopen::DriveState::kSwitchOnDisabled);
  d.fault();
  d.tick();
  EXPECT_EQ(d.apply(kCwFaultReset), 0) << "bit 7 still up from the last reset: no edge";
  EXPECT_EQ(d.apply(kCwDisableVoltage), 0);
  EXPECT_EQ(d.apply(kCwFaultReset), 15);
  // Every state's statusword reads back as that state, with the extra bits kept out of its own.
  for (const std::uint16_t extra : {std::uint16_t{0}, std::uint16_t{0xFFFF}}) {
    DriveStateMachine m;
    auto expect_self = [&] { EXPECT_EQ(decode_statusword(m.statusword(extra)), m.state()) << to_string(m.state()); };
    expect_self();
    m.tick();
    expect_self();
    for (const std::uint16_t cw : {kCwShutdown, kCwSwitchOn, kCwEnableOperation, kCwQuickStop}) {
      (void)m.apply(cw);
      expect_self();
    }
    m.fault();
    expect_self();
    m.tick();
    expect_self();
  }
}

TEST(Cia402, TheMastersControlwordsBringADriveToOperationEnabledAndFaultsStayUntilAReset) {
  DriveStateMachine d;
  d.tick();
  std::uint16_t cw = 0;
  int steps = 0;
  while (!d.enabled() && steps < 10) {
    cw = next_controlword(*decode_statusword(d.statusword()), true, false, cw);
    (void)d.apply(cw);
    ++steps;
  }
  EXPECT_TRUE(d.enabled());
  EXPECT_EQ(steps, 3) << "shutdown, switch on, enable operation";
  EXPECT_EQ(next_controlword(canopen::DriveState::kOperationEnabled, true, false, cw), kCwEnableOperation) << "held";
  // Limp on request: disable voltage from any state.
  for (auto s : {canopen::DriveState::kOperationEnabled, canopen::DriveState::kSwitchedOn, canopen::DriveState::kReadyToSwitchOn, canopen::DriveState::kQuickStopActive}) {
    EXPECT_EQ(next_controlword(s, false, false, kCwEnableOperation), kCwDisableVoltage) << to_string(s);
  }
  // A fault: no reset unless asked; asked, a rising edge on bit 7, then on to operation enabled.
  d.fault();
  d.tick();
  for (int k = 0; k < 5; ++k) {
    cw = next_controlword(*decode_statusword(d.statusword()), true, false, cw);
    (void)d.apply(cw);
  }
  EXPECT_EQ(d.state(), canopen::DriveState::kFault);
  steps = 0;
  bool reset_asked = true;
  while (!d.enabled() && steps < 10) {
    cw = next_controlword(*decode_statusword(d.statusword()), true, reset_asked, cw);
    if (d.apply(cw) == 15) reset_asked = false;
    ++steps;
  }
  EXPECT_TRUE(d.enabled());
  EXPECT_EQ(steps, 4) << "fault reset, shutdown, switch on, enable operation";
  // After a quick stop the master takes the drive down through switch on disabled.
  EXPECT_EQ(next_controlword(canopen::DriveState::kQuickStopActive, true, false, kCwEnableOperation), kCwDisableVoltage);
  // A reset asked for while bit 7 is already up first drops it.
  EXPECT_EQ(next_controlword(canopen::DriveState::kFault, true, true, kCwFaultReset), kCwDisableVoltage);
  EXPECT_EQ(next_controlword(canopen::DriveState::kFault, true, true, kCwDisableVoltage), kCwFaultReset);
}

}  // namespace
