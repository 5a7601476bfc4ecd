// Every LCM type's decoder against forged counts and lengths: a malformed message is refused
// (decode returns -1) without throwing and without allocating more than the message could hold.
#include <gtest/gtest.h>

#include <climits>
#include <cstring>

#include "all_types.hpp"
#include "allocation_counter.hpp"

namespace {

// Overwrites 4 bytes at every offset after the hash with forged int32 values (big-endian, as LCM
// writes them) and decodes: counts of 2e7, INT32_MAX, -1 and INT32_MIN, and zero string lengths.
template <class Msg>
void forge_every_int32(const std::string& name) {
  hpr::test::Filler filler(7);
  Msg m{};
  filler.fill(m);
  const int size = m.getEncodedSize();
  std::vector<std::uint8_t> good(static_cast<size_t>(size));
  ASSERT_EQ(m.encode(good.data(), 0, size), size) << name;
  int refused = 0;
  for (int at = 8; at + 4 <= size; ++at) {
    for (const std::int32_t forged : {20'000'000, INT_MAX, -1, INT_MIN, 0}) {
      std::vector<std::uint8_t> bad = good;
      const auto u = static_cast<std::uint32_t>(forged);
      bad[static_cast<size_t>(at)] = static_cast<std::uint8_t>(u >> 24);
      bad[static_cast<size_t>(at) + 1] = static_cast<std::uint8_t>(u >> 16);
      bad[static_cast<size_t>(at) + 2] = static_cast<std::uint8_t>(u >> 8);
      bad[static_cast<size_t>(at) + 3] = static_cast<std::uint8_t>(u);
      Msg out{};
      const long before = hpr::test::allocated_bytes();
      int used = 0;
      ASSERT_NO_THROW(used = out.decode(bad.data(), 0, size)) << name << " forged " << forged << " at byte " << at;
      // Whatever was decoded fits what the message could hold: each element takes at least a byte,
      // a std::string or vector element at most 32 bytes of bookkeeping.
      EXPECT_LE(hpr::test::allocated_bytes() - before, 64L * size + 4096)
          << name << " forged " << forged << " at byte " << at;
      if (used < 0) ++refused;
    }
  }
  if (name != "CAM_REFERENCE") {  // the one type without a variable-length field
    EXPECT_GT(refused, 0) << name << ": no forged count was refused";
  }
}

TEST(Decode, ForgedCountsAndLengthsAreRefusedWithoutThrowingOrAllocating) {
  hpr::test::for_each_type([]<class Msg>(const std::string& name) { forge_every_int32<Msg>(name); });
}

TEST(Decode, AHugeJointCountInASmallMessageAllocatesNothingLarge) {
  // The probe's case: a small ROBOT_SENSORS declaring 20 000 000 joints.
  humanoid::robot_sensors_t m{};
  const int size = m.getEncodedSize();
  std::vector<std::uint8_t> buf(static_cast<size_t>(size));
  ASSERT_EQ(m.encode(buf.data(), 0, size), size);
  const std::uint32_t n = 20'000'000;
  const int at = 8 + 8 + 8 + 8;  // hash, tick, utime, source, then num_joints
  for (int k = 0; k < 4; ++k) buf[static_cast<size_t>(at + k)] = static_cast<std::uint8_t>(n >> (24 - 8 * k));
  const long before = hpr::test::allocated_bytes();
  humanoid::robot_sensors_t out{};
  EXPECT_EQ(out.decode(buf.data(), 0, size), -1);
  EXPECT_LT(hpr::test::allocated_bytes() - before, 4096);
}

// A string must end at its terminator: a NUL inside it, or a last byte that is not NUL, makes the
// message malformed. (lcm-gen's encoder writes a string up to its first NUL, so a decoded string
// holding one would be re-published as a different, shifted message.)
TEST(Decode, AStringWithANulInsideOrNoTerminatorIsRefused) {
  humanoid::health_t m{};
  m.node = "wbc";
  m.host = "robot";
  const auto good = hpr::test::encode(m);
  humanoid::health_t out{};
  ASSERT_EQ(out.decode(good.data(), 0, static_cast<int>(good.size())), static_cast<int>(good.size()));
  EXPECT_EQ(out.node, "wbc");
  // The node name's bytes follow the hash (8), tick (8), utime (8) and its length (4).
  const std::size_t at = 8 + 8 + 8 + 4;
  ASSERT_EQ(good[at], 'w');
  auto inside = good;
  inside[at + 1] = 0;  // "w\0c"
  EXPECT_EQ(out.decode(inside.data(), 0, static_cast<int>(inside.size())), -1);
  auto unterminated = good;
  unterminated[at + 3] = 'x';  // "wbcx" where the NUL should be
  EXPECT_EQ(out.decode(unterminated.data(), 0, static_cast<int>(unterminated.size())), -1);
}

}  // namespace
