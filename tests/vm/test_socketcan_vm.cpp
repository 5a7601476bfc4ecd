// SocketCAN for real, on a kernel that has CAN: tests/vm/can-vm boots Debian's kernel under qemu
// with an initramfs of the host's packages and this build's hal and drive emulator, creates vcan
// interfaces can0..can9, runs the drive emulator and the hal on them with the socketcan transport
// and candump on can0, on the emulator's simulated clock. Skipped (with the reason) when qemu or the kernel image is missing.
#include <gtest/gtest.h>

#include <regex>

#include "process_group.hpp"
#include "shell.hpp"

namespace {

long number_after(const std::string& text, const std::string& marker) {
  const auto p = text.find(marker);
  if (p == std::string::npos) return -1;
  return std::strtol(text.c_str() + p + marker.size(), nullptr, 10);
}

TEST(SocketCanVm, HalAndDriveEmulatorTalkOverVcanAndCandumpSeesTheFrames) {
  const std::string work = hpr::test::temp_dir("can-vm");
  const auto r = hpr::test::run_command({hpr::test::source_dir() + "/tests/vm/can-vm", hpr::test::bin_dir(), hpr::test::source_dir(), work, "0.3"});
  if (r.exit_code == 77) GTEST_SKIP() << r.out;
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const std::string& out = r.out;
  ASSERT_NE(out.find("VM: done"), std::string::npos) << "the VM did not finish:\n" << out;
  EXPECT_NE(out.find("VM: CAN ready"), std::string::npos) << out;
  EXPECT_EQ(out.find("insmod"), std::string::npos) << "a CAN module did not load:\n" << out;
  EXPECT_NE(out.find("can0 can1 can2"), std::string::npos) << out;
  EXPECT_EQ(number_after(out, "VM: hal exit "), 0) << out;
  // candump on can0 saw the hal's MIT-mode commands (ids 1-3) and every drive's reply (0x101-0x103).
  const long commands = number_after(out, "VM: candump commands "), replies = number_after(out, "VM: candump replies ");
  EXPECT_GT(commands, 100) << out;
  EXPECT_GE(replies, commands * 9 / 10) << out;
  // The hal on SocketCAN, on the emulator's clock: every reply of every tick decoded (the hal waits
  // for the tick's clock frame, so this does not depend on how fast the emulation runs), no
  // malformed frame.
  const std::regex stop("hal stopped after ([0-9]+) ticks.*malformed frames ([0-9]+); replies missed ([0-9]+) of ([0-9]+)");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, stop)) << out;
  EXPECT_GT(std::stol(m[1]), 100);
  EXPECT_EQ(std::stol(m[2]), 0) << "malformed frames";
  EXPECT_EQ(std::stol(m[3]), 0) << "replies missed:\n" << out;
  EXPECT_EQ(std::stol(m[4]), std::stol(m[1]) * 27) << "27 drives every tick";
}

// The same with every drive speaking CANopen CiA 402: the start-up (NMT, SDO configuration) and the
// cyclic frames on the wire as candump sees them, through the SocketCAN receive filters of both ends.
TEST(SocketCanVm, Cia402DrivesStartAndRunOverVcan) {
  const std::string work = hpr::test::temp_dir("can-vm-cia402");
  const auto r = hpr::test::run_command(
      {hpr::test::source_dir() + "/tests/vm/can-vm", hpr::test::bin_dir(), hpr::test::source_dir(), work, "0.4", "cia402"});
  if (r.exit_code == 77) GTEST_SKIP() << r.out;
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const std::string& out = r.out;
  ASSERT_NE(out.find("VM: done"), std::string::npos) << "the VM did not finish:\n" << out;
  EXPECT_EQ(number_after(out, "VM: hal exit "), 0) << out;
  EXPECT_EQ(number_after(out, "VM: candump commands "), 0) << "no MIT-mode frame";
  // Start-up: NMT reset communication and NMT start for the bus (one each per node: 3 drives on
  // can0), the 3 SDO reads and 23 writes of the start-up per drive (docs/CAN.md), each answered.
  EXPECT_EQ(number_after(out, "VM: candump nmt "), 6) << out;
  EXPECT_EQ(number_after(out, "VM: candump sdo requests "), 3 * 26) << out;
  EXPECT_EQ(number_after(out, "VM: candump sdo answers "), 3 * 26) << out;
  const long rpdo = number_after(out, "VM: candump rpdo1 "), tpdo1 = number_after(out, "VM: candump tpdo1 "),
             tpdo2 = number_after(out, "VM: candump tpdo2 ");
  EXPECT_GT(rpdo, 100) << out;
  EXPECT_GE(tpdo1, rpdo) << "each drive answers every SYNC once operational";
  EXPECT_EQ(tpdo1, tpdo2) << out;
  EXPECT_NE(out.find("CiA 402 drives started in"), std::string::npos) << out;
  EXPECT_NE(out.find("enabled by configuration"), std::string::npos) << out;
  const std::regex stop("hal stopped after ([0-9]+) ticks.*malformed frames ([0-9]+); replies missed ([0-9]+) of ([0-9]+)");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, stop)) << out;
  EXPECT_EQ(std::stol(m[2]), 0) << "malformed frames";
  EXPECT_EQ(std::stol(m[3]), 0) << "replies missed:\n" << out;
}

}  // namespace
