// The attack on a node's own LCM reader (hpr/node/udpm.hpp): tiny datagrams, each the first
// fragment of a 16 MB message, at 1 kHz for 5 s, on a channel the node reads and on one it does not,
// beside the live 1 kHz stream. Nothing is allocated for them, the node's memory does not grow, and
// the live stream arrives as without them. Run alone (SERIAL): it measures the process's memory
// and counts messages on the loopback.
#include <gtest/gtest.h>
#include <humanoid/robot_sensors_t.hpp>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
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

/// The process's resident memory [bytes] (/proc/self/statm).
std::int64_t resident_bytes() {
  std::ifstream f("/proc/self/statm");
  std::int64_t size = 0, resident = 0;
  f >> size >> resident;
  return resident * ::sysconf(_SC_PAGESIZE);
}

/// A first fragment of a message of `total` bytes on `channel` (LCM's LC03 header, big-endian).
std::vector<std::uint8_t> first_fragment(const std::string& channel, std::uint32_t total, std::uint32_t seqno) {
  std::vector<std::uint8_t> b;
  const auto put32 = [&](std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) b.push_back(static_cast<std::uint8_t>(v >> s));
  };
  put32(0x4c433033);
  put32(seqno);
  put32(total);
  put32(0);
  b.push_back(0);
  b.push_back(0);  // fragment 0
  b.push_back(0x01);
  b.push_back(0x00);  // of 256
  b.insert(b.end(), channel.begin(), channel.end());
  b.push_back(0);
  b.insert(b.end(), {1, 2, 3, 4});
  return b;
}

struct FloodRun {
  std::int64_t sent = 0, received = 0, flood = 0, refused = 0;
  std::size_t peak_partial = 0;
  std::int64_t rss_growth = 0;
};

/// 5 s of the live stream at 1 kHz into a node reading directly, with or without the flood.
FloodRun run_stream(bool flood) {
  const std::string url = hpr::test::unique_lcm_url();
  hpr::node::RuntimeOptions o;
  o.authenticate = false;
  o.health_period_s = 10.0;
  o.receive_direct = true;
  static constexpr hpr::Read kReads[] = {{"SENSORS", 0, false, false, "the live stream"}};
  static constexpr hpr::Ports kPorts{.name = "test", .reads = kReads, .writes = {}};
  hpr::node::Runtime rt(kPorts, "test", url, o);
  auto& in = rt.subscribe(hpr::Channel<humanoid::robot_sensors_t>{"SENSORS"});
  FloodRun r;
  const std::int64_t rss0 = resident_bytes();
  std::atomic<bool> done{false};
  std::thread live([&] {
    lcm::LCM sender(url);
    humanoid::robot_sensors_t m{};
    auto next = std::chrono::steady_clock::now();
    for (int k = 1; k <= 5000; ++k) {
      m.tick = k;
      m.utime = k * 1000;
      sender.publish("SENSORS", &m);
      ++r.sent;
      next += std::chrono::milliseconds(1);
      std::this_thread::sleep_until(next);
    }
    done = true;
  });
  std::thread forger([&] {
    if (!flood) return;
    hpr::test::MulticastSender forged(url);
    auto next = std::chrono::steady_clock::now();
    for (std::uint32_t k = 0; !done; ++k) {
      const auto d = first_fragment(k % 2 == 0 ? "SENSORS" : "NOBODY_READS", 16u << 20, k);
      if (forged.send(d.data(), d.size())) ++r.flood;
      next += std::chrono::milliseconds(1);
      std::this_thread::sleep_until(next);
    }
  });
  while (!done) rt.spin_once(0.01);
  const auto settle = std::chrono::steady_clock::now() + std::chrono::milliseconds(300);
  while (std::chrono::steady_clock::now() < settle) rt.spin_once(0.01);
  live.join();
  forger.join();
  r.received = in.count();
  const hpr::node::UdpmReceiver* reader = rt.transport().direct_receiver();
  r.refused = reader->refused();
  r.peak_partial = reader->datagrams().peak_partial_bytes();
  r.rss_growth = resident_bytes() - rss0;
  return r;
}

TEST(UdpmFlood, FirstFragmentsDeclaring16MBCostTheNodeNoMemoryAndNoMessage) {
  const FloodRun quiet = run_stream(false);
  const FloodRun attacked = run_stream(true);
  std::cout << "live messages received: " << quiet.received << " of " << quiet.sent << " without the flood, " << attacked.received
            << " of " << attacked.sent << " with " << attacked.flood << " forged first fragments (" << attacked.refused
            << " refused); resident memory grew " << attacked.rss_growth / 1024 << " kB\n";
  ASSERT_GT(attacked.flood, 4000) << "the flood was not sent";
  EXPECT_GE(attacked.refused, attacked.flood * 99 / 100) << "forged fragments taken";
  EXPECT_EQ(attacked.peak_partial, 0U) << "memory allocated for a forged message";
  EXPECT_LT(attacked.rss_growth, 4 << 20);
  // The live stream arrives as without the flood (within 1 % of the messages sent).
  EXPECT_GE(attacked.received, quiet.received - attacked.sent / 100);
}

}  // namespace
