// Configuring a CiA 402 drive over SDO: the client's writes against a drive served from its EDS,
// the configuration a conforming drive ends with (read back from the drive's objects), and a
// refusal or silence reported with the node, the object, the value, its purpose and the abort
// code's meaning.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>

#include "hpr/hal/canopen_sdo.hpp"

namespace {

using namespace hpr::hal;
using namespace hpr::hal::canopen;

std::string var(const std::string& section, const std::string& name, const std::string& type, const std::string& access,
                const std::string& value = "", bool mappable = false) {
  std::string s = "[" + section + "]\nParameterName=" + name + "\nObjectType=0x7\nDataType=" + type + "\nAccessType=" + access + "\n";
  if (!value.empty()) s += "DefaultValue=" + value + "\n";
  return s + "PDOMapping=" + (mappable ? "1" : "0") + "\n\n";
}

std::string record(const std::string& index, int subs) {
  return "[" + index + "]\nParameterName=record\nObjectType=0x9\nSubNumber=" + std::to_string(subs) + "\n\n";
}

/// A CiA 402 drive's data sheet: the PDO parameters and the drive profile's objects; the target
/// torque mappable or not.
std::string drive_eds(bool torque_mappable = true, bool modes = true) {
  std::string e = var("1000", "Device type", "0x0007", "ro", "0x00020192") + var("1017", "Producer heartbeat time", "0x0006", "rw", "0");
  for (const auto& [comm, cob] : {std::pair<std::string, std::string>{"1400", "$NODEID+0x200"}, {"1800", "$NODEID+0x180"}, {"1801", "$NODEID+0x280"}}) {
    e += record(comm, 3) + var(comm + "sub0", "Highest sub-index", "0x0005", "const", "2") +
         var(comm + "sub1", "COB-ID", "0x0007", "rw", cob) + var(comm + "sub2", "Transmission type", "0x0005", "rw", "255");
  }
  for (const std::string map : {"1600", "1A00", "1A01"}) {
    e += record(map, 5) + var(map + "sub0", "Number of mapped objects", "0x0005", "rw", "0");
    for (int k = 1; k <= 4; ++k) e += var(map + "sub" + std::to_string(k), "Mapping entry", "0x0007", "rw", "0");
  }
  e += var("6040", "Controlword", "0x0006", "rww", "0", true) + var("6041", "Statusword", "0x0006", "ro", "0", true) +
       var("6064", "Position actual value", "0x0004", "ro", "0", true) + var("606C", "Velocity actual value", "0x0004", "ro", "0", true) +
       var("6071", "Target torque", "0x0003", "rww", "0", torque_mappable) + var("6077", "Torque actual value", "0x0003", "ro", "0", true);
  if (modes) e += var("6060", "Modes of operation", "0x0002", "rw", "0");
  return e;
}

/// Runs the sequence against the server, one millisecond per exchange; returns the frames sent.
int run(SdoSequence& seq, SdoServer* server, double until = 1.0) {
  int sent = 0;
  for (double t = 0.0; t < until && !seq.done() && !seq.failed(); t += 1e-3) {
    if (const auto f = seq.poll(t)) {
      ++sent;
      if (server != nullptr) {
        if (const auto answer = server->on_frame(*f)) seq.on_frame(*answer, t);
      }
    }
  }
  return sent;
}

TEST(Cia402Configuration, AConformingDriveEndsWithTheCyclicSynchronousTorqueMapping) {
  const ObjectDictionary od = ObjectDictionary::parse(drive_eds(), "drive.eds");
  SdoServer drive(5, od);
  SdoSequence seq(5, cst_configuration(5, 100), 0.1);
  EXPECT_EQ(run(seq, &drive), 23) << "RPDO1 7 writes, TPDO1 8, TPDO2 6, the mode and the heartbeat";
  ASSERT_TRUE(seq.done()) << seq.error();
  // Read back from the drive's objects, in CiA 301's encoding (index << 16 | subindex << 8 | bits):
  // (index, subindex, value).
  const std::uint64_t expected[][3] = {
      {0x1400, 1, 0x205},  // RPDO1 enabled on 0x200 + 5
      {0x1400, 2, 1},      // synchronous
      {0x1600, 0, 2},      {0x1600, 1, 0x60400010}, {0x1600, 2, 0x60710010},
      {0x1800, 1, 0x185},  {0x1A00, 0, 3},          {0x1A00, 1, 0x60410010}, {0x1A00, 2, 0x60770010}, {0x1A00, 3, 0x60640020},
      {0x1801, 1, 0x285},  {0x1A01, 1, 0x606C0020}, {0x6060, 0, 10},         {0x1017, 0, 100}};
  for (const auto& [index, sub, value] : expected) {
    EXPECT_EQ(drive.value(static_cast<std::uint16_t>(index), static_cast<std::uint8_t>(sub)), value) << std::hex << index << ":" << sub;
  }
}

TEST(Cia402Configuration, ARefusalNamesTheNodeTheObjectTheValueItsPurposeAndTheAbortCodesMeaning) {
  const ObjectDictionary od = ObjectDictionary::parse(drive_eds(false), "drive.eds");
  SdoServer drive(5, od);
  SdoSequence seq(5, cst_configuration(5, 100), 0.1);
  (void)run(seq, &drive);
  ASSERT_TRUE(seq.failed());
  EXPECT_EQ(seq.error(),
            "node 5: SDO write 0x1600:02 = 0x60710010 (RPDO1 mapping 2: target torque) refused: abort 0x06040041 (object "
            "cannot be mapped to the PDO)");
  EXPECT_EQ(seq.confirmed(), 4U) << "the writes before it were taken";
  EXPECT_EQ(drive.value(0x1400, 1), 0x80000205U) << "the PDO stays disabled";

  const ObjectDictionary no_modes = ObjectDictionary::parse(drive_eds(true, false), "drive.eds");
  SdoServer drive2(5, no_modes);
  SdoSequence seq2(5, cst_configuration(5, 100), 0.1);
  (void)run(seq2, &drive2);
  EXPECT_EQ(seq2.error(),
            "node 5: SDO write 0x6060:00 = 0x0A (mode of operation: cyclic synchronous torque) refused: abort 0x06020000 "
            "(object does not exist in the object dictionary)");
}

TEST(Cia402Configuration, ASilentDriveIsReportedAfterTheTimeoutWithOneRequestSent) {
  SdoSequence seq(7, cst_configuration(7, 100), 0.1);
  EXPECT_EQ(run(seq, nullptr), 1);
  ASSERT_TRUE(seq.failed());
  EXPECT_EQ(seq.error(), "node 7: SDO write 0x1400:01 = 0x80000207 (RPDO1 disabled while it is mapped): no answer within 0.100 s");
  // Another node's answer, or another service's frame, is not taken for it.
  SdoSequence seq2(7, cst_configuration(7, 100), 0.1);
  ASSERT_TRUE(seq2.poll(0.0));
  seq2.on_frame(sdo_download_done(8, {0x1400, 1}), 0.001);
  seq2.on_frame(heartbeat(7, NmtState::kPreOperational), 0.001);
  EXPECT_EQ(seq2.confirmed(), 0U);
  EXPECT_FALSE(seq2.failed());
  seq2.on_frame(sdo_download_done(7, {0x1400, 1}), 0.002);
  EXPECT_EQ(seq2.confirmed(), 1U);
}

TEST(Cia402Configuration, TheServerRefusesAsCiA301Says) {
  const ObjectDictionary od = ObjectDictionary::parse(drive_eds(), "drive.eds");
  SdoServer drive(5, od);
  auto abort_of = [&](const CanFrame& request) -> std::uint32_t {
    const auto answer = drive.on_frame(request);
    EXPECT_TRUE(answer);
    const auto m = decode_sdo(*answer, 5);
    EXPECT_TRUE(m);
    return m->kind == SdoMessage::Kind::kAbort ? m->value : 0;
  };
  EXPECT_EQ(abort_of(sdo_download(5, {0x6041, 0}, 1, 2)), kAbortReadOnly);
  EXPECT_EQ(abort_of(sdo_download(5, {0x1400, 0}, 1, 1)), kAbortReadOnly) << "const";
  EXPECT_EQ(abort_of(sdo_download(5, {0x6040, 0}, 1, 4)), kAbortLengthMismatch) << "a 16-bit object written with 4 bytes";
  EXPECT_EQ(abort_of(sdo_upload(5, {0x2000, 0})), kAbortNoObject);
  EXPECT_EQ(abort_of(sdo_upload(5, {0x1400, 9})), kAbortNoSubindex);
  EXPECT_EQ(abort_of(sdo_download(5, {0x1A00, 1}, 0x60400020, 4)), 0x06040041U) << "mapped with another length than its own";
  EXPECT_EQ(abort_of(sdo_download(5, {0x6040, 0}, 0x0F, 2)), 0U);
  const auto read = decode_sdo(*drive.on_frame(sdo_upload(5, {0x1000, 0})), 5);
  EXPECT_EQ(read->kind, SdoMessage::Kind::kUploadData);
  EXPECT_EQ(read->value, 0x00020192U);
  EXPECT_FALSE(drive.on_frame(sdo_upload(6, {0x1000, 0}))) << "another node's request";
}

}  // namespace
