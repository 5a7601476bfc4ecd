// The own LCM receive path (hpr/node/udpm.hpp) against liblcm's sender over real multicast: every
// message liblcm publishes, short or fragmented, arrives byte for byte on its channel, stamped
// with the instant it was published; a typed input reads the same through it as through liblcm;
// a datagram that is not LCM's is refused and loses nothing.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <humanoid/robot_sensors_t.hpp>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <thread>
#include <vector>

#include "hpr/node/lcm_url.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/node/udpm.hpp"
#include "multicast_sender.hpp"
#include "process_group.hpp"

namespace {

using Bytes = std::vector<std::uint8_t>;

std::int64_t realtime_us() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000 + ts.tv_nsec / 1000;
}

struct Received {
  std::string channel;
  Bytes payload;
  std::int64_t utime;
};

/// Reads `socket` until `n` messages arrived or 5 s passed.
std::vector<Received> receive(hpr::node::UdpmReceiver& socket, std::size_t n) {
  std::vector<Received> got;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (got.size() < n && std::chrono::steady_clock::now() < end) {
    pollfd p{socket.fd(), POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    socket.drain([&](std::string_view ch, const std::uint8_t* data, std::size_t size, std::int64_t utime) {
      got.push_back({std::string(ch), Bytes(data, data + size), utime});
    });
  }
  return got;
}

TEST(Udpm, EveryMessageLiblcmPublishesArrivesByteForByteShortOrFragmented) {
  const std::string url = hpr::test::unique_lcm_url();
  hpr::node::UdpmReceiver socket(hpr::node::parse_udpm_url(hpr::node::with_receive_buffer(url)));
  lcm::LCM sender(url);
  ASSERT_TRUE(sender.good());
  // Sizes around liblcm's single-datagram limit (65 499 bytes with the channel) and well beyond it.
  const std::vector<std::size_t> sizes = {0, 1, 1496, 65'000, 65'480, 65'500, 65'600, 300'000, 1'000'000};
  std::vector<Bytes> sent;
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    Bytes b(sizes[i]);
    for (std::size_t k = 0; k < b.size(); ++k) b[k] = static_cast<std::uint8_t>((k * 7 + i) % 256);
    sent.push_back(b);
    ASSERT_EQ(sender.publish("SIZE_" + std::to_string(i), b.data(), static_cast<unsigned>(b.size())), 0);
    // Paced: the socket buffer (4 MB) holds them all anyway, but the loopback queue per CPU is smaller.
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const auto got = receive(socket, sizes.size());
  ASSERT_EQ(got.size(), sizes.size());
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    EXPECT_EQ(got[i].channel, "SIZE_" + std::to_string(i));
    EXPECT_EQ(got[i].payload, sent[i]) << sizes[i] << " bytes";
  }
  EXPECT_EQ(socket.refused(), 0) << socket.last_refusal();
}

TEST(Udpm, AMessageIsStampedWhenItWasPublishedNotWhenItWasRead) {
  const std::string url = hpr::test::unique_lcm_url();
  hpr::node::UdpmReceiver socket(hpr::node::parse_udpm_url(url));
  lcm::LCM sender(url);
  ASSERT_TRUE(sender.good());
  const Bytes b(1496, 1);
  // The kernel turns its receive timestamps on shortly after the first socket asks for them (a
  // deferred switch): until then a message is stamped when it is read. So publish, read 50 ms
  // later, until the stamp lies within the publish call; it must within 2 s, and from then on.
  const auto publish_and_read_late = [&](std::int64_t& before, std::int64_t& after) {
    before = realtime_us();
    EXPECT_EQ(sender.publish("STAMPED", b.data(), static_cast<unsigned>(b.size())), 0);
    after = realtime_us();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // read late: the stamp must not move
    const auto got = receive(socket, 1);
    return got.size() == 1 ? got[0].utime : -1;
  };
  std::int64_t before = 0, after = 0, stamp = -1;
  for (int attempt = 0; attempt < 40; ++attempt) {
    stamp = publish_and_read_late(before, after);
    if (stamp >= before && stamp <= after) break;
  }
  ASSERT_GE(stamp, before) << "no message stamped within its publish call in 40 attempts";
  ASSERT_LE(stamp, after) << "no message stamped within its publish call in 40 attempts";
  for (int k = 0; k < 5; ++k) {
    stamp = publish_and_read_late(before, after);
    EXPECT_GE(stamp, before);
    EXPECT_LE(stamp, after) << "stamped " << stamp - after << " us after the publish returned";
  }
}

/// A Runtime's typed input on `url`, read directly or through liblcm.
class TypedInput : public ::testing::TestWithParam<bool> {};

TEST_P(TypedInput, ReadsWhatLiblcmPublishesAndRefusesAForeignDatagramWithoutLosingTheNext) {
  const std::string url = hpr::test::unique_lcm_url();
  hpr::node::RuntimeOptions o;
  o.authenticate = false;
  o.health_period_s = 10.0;
  o.receive_direct = GetParam();
  static constexpr hpr::Read kReads[] = {{"SENSORS", 0, false, false, "the input read"}};
  static constexpr hpr::Ports kPorts{.name = "test", .reads = kReads, .writes = {}};
  hpr::node::Runtime rt(kPorts, "test", url, o);
  EXPECT_EQ(rt.receives_directly(), GetParam());
  auto& in = rt.subscribe(hpr::Channel<humanoid::robot_sensors_t>{"SENSORS"});
  lcm::LCM sender(url);
  ASSERT_TRUE(sender.good());
  const auto wait_for_count = [&](std::int64_t n) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (in.count() < n && std::chrono::steady_clock::now() < end) rt.spin_once(0.05);
    return in.count() >= n;
  };
  humanoid::robot_sensors_t m{};
  m.tick = 11;
  m.utime = 11'000;
  m.num_joints = 2;
  m.joint_name = {"a", "b"};
  m.q = {0.5, -0.25};
  m.qd = {0.0, 1.0};
  m.tau = {3.0, 4.0};
  m.drive_status = {1, 1};
  sender.publish("SENSORS", &m);
  sender.publish("OTHER", &m);  // not subscribed: not delivered
  ASSERT_TRUE(wait_for_count(1));
  EXPECT_EQ(in.latest().tick, 11);
  EXPECT_EQ(in.latest().q, m.q);
  // A datagram on LCM's group and port that is not LCM's format, then a good message.
  {
    hpr::test::MulticastSender stranger(url);
    ASSERT_TRUE(stranger.good());
    const char junk[] = "not an LCM datagram";
    ASSERT_TRUE(stranger.send(junk, sizeof junk));
  }
  m.tick = 12;
  m.utime = 12'000;
  sender.publish("SENSORS", &m);
  ASSERT_TRUE(wait_for_count(2));
  EXPECT_EQ(in.latest().tick, 12);
  EXPECT_EQ(in.errors(), 0);
}

std::string receive_path(const ::testing::TestParamInfo<bool>& p) { return p.param ? "Direct" : "ThroughLiblcm"; }
INSTANTIATE_TEST_SUITE_P(Udpm, TypedInput, ::testing::Values(true, false), receive_path);

}  // namespace
