// LCM's datagram format read without liblcm (hpr/node/udpm.hpp): messages whole and in fragments,
// and every malformed datagram refused with its reason. The datagrams are built here by hand from
// the format; tests/integration/test_udpm.cpp checks the same reader against liblcm's own sender.
#include "hpr/node/udpm.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "hpr/node/lcm_url.hpp"

namespace {

using hpr::node::LcmDatagrams;
using Bytes = std::vector<std::uint8_t>;

void put32(Bytes& b, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) b.push_back(static_cast<std::uint8_t>(v >> s));
}
void put16(Bytes& b, std::uint16_t v) {
  b.push_back(static_cast<std::uint8_t>(v >> 8));
  b.push_back(static_cast<std::uint8_t>(v));
}

Bytes short_datagram(const std::string& channel, const Bytes& payload, std::uint32_t seqno = 7) {
  Bytes b;
  put32(b, 0x4c433032);
  put32(b, seqno);
  b.insert(b.end(), channel.begin(), channel.end());
  b.push_back(0);
  b.insert(b.end(), payload.begin(), payload.end());
  return b;
}

/// Fragment `no` of `count` of a `payload` split every `step` bytes, as liblcm sends them.
Bytes fragment(const std::string& channel, const Bytes& payload, std::uint32_t seqno, std::uint16_t no, std::uint16_t count, std::size_t step) {
  Bytes b;
  put32(b, 0x4c433033);
  put32(b, seqno);
  put32(b, static_cast<std::uint32_t>(payload.size()));
  const std::size_t offset = no * step;
  put32(b, static_cast<std::uint32_t>(offset));
  put16(b, no);
  put16(b, count);
  if (no == 0) {
    b.insert(b.end(), channel.begin(), channel.end());
    b.push_back(0);
  }
  const std::size_t end = std::min(payload.size(), offset + step);
  b.insert(b.end(), payload.begin() + static_cast<std::ptrdiff_t>(offset), payload.begin() + static_cast<std::ptrdiff_t>(end));
  return b;
}

Bytes pattern(std::size_t n) {
  Bytes p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<std::uint8_t>((i * 131 + 7) % 251);
  return p;
}

struct Received {
  std::string channel;
  Bytes payload;
  std::int64_t utime;
};

struct Reader {
  LcmDatagrams datagrams;
  std::vector<Received> got;
  std::string feed(const Bytes& b, std::uint64_t sender = 1, std::int64_t utime = 1000) {
    return datagrams.feed(b.data(), b.size(), sender, utime, [&](std::string_view ch, const std::uint8_t* p, std::size_t n, std::int64_t t) {
      got.push_back({std::string(ch), Bytes(p, p + n), t});
    });
  }
};

TEST(LcmDatagrams, AShortMessageIsItsChannelAndPayload) {
  Reader r;
  const Bytes payload = pattern(1496);
  EXPECT_EQ(r.feed(short_datagram("ROBOT_SENSORS", payload), 1, 42), "");
  ASSERT_EQ(r.got.size(), 1u);
  EXPECT_EQ(r.got[0].channel, "ROBOT_SENSORS");
  EXPECT_EQ(r.got[0].payload, payload);
  EXPECT_EQ(r.got[0].utime, 42);
  // An empty payload is a message too.
  EXPECT_EQ(r.feed(short_datagram("EMPTY", {})), "");
  ASSERT_EQ(r.got.size(), 2u);
  EXPECT_TRUE(r.got[1].payload.empty());
}

TEST(LcmDatagrams, FragmentsMakeOneMessageInAnyOrderAfterTheFirstAndOnlyWhenAllArrived) {
  const Bytes payload = pattern(200'000);
  const std::size_t step = 65'000;
  const std::uint16_t count = 4;
  for (const std::vector<std::uint16_t>& order : {std::vector<std::uint16_t>{0, 1, 2, 3}, {0, 3, 1, 2}, {0, 2, 3, 1}}) {
    Reader r;
    for (std::size_t i = 0; i < order.size(); ++i) {
      EXPECT_EQ(r.feed(fragment("BIG", payload, 9, order[i], count, step), 5, 100 + static_cast<std::int64_t>(i)), "");
      if (i + 1 < order.size()) {
        EXPECT_TRUE(r.got.empty()) << "delivered before fragment " << order[i + 1];
      }
    }
    ASSERT_EQ(r.got.size(), 1u);
    EXPECT_EQ(r.got[0].channel, "BIG");
    EXPECT_EQ(r.got[0].payload, payload);
    EXPECT_EQ(r.got[0].utime, 103) << "the time of the last datagram";
  }
}

TEST(LcmDatagrams, ARepeatedFragmentIsTakenOnceAndSendersAreKeptApart) {
  const Bytes a = pattern(100'000), b = Bytes(90'000, 0x5a);
  const std::size_t step = 60'000;
  Reader r;
  EXPECT_EQ(r.feed(fragment("A", a, 1, 0, 2, step), 1), "");
  EXPECT_EQ(r.feed(fragment("B", b, 1, 0, 2, step), 2), "");  // another sender, the same sequence number
  EXPECT_EQ(r.feed(fragment("A", a, 1, 0, 2, step), 1), "");  // a copy
  EXPECT_TRUE(r.got.empty());
  EXPECT_EQ(r.feed(fragment("B", b, 1, 1, 2, step), 2), "");
  EXPECT_EQ(r.feed(fragment("A", a, 1, 1, 2, step), 1), "");
  ASSERT_EQ(r.got.size(), 2u);
  EXPECT_EQ(r.got[0].channel, "B");
  EXPECT_EQ(r.got[0].payload, b);
  EXPECT_EQ(r.got[1].channel, "A");
  EXPECT_EQ(r.got[1].payload, a);
}

TEST(LcmDatagrams, ANewerMessageDropsTheUnfinishedOneOfItsSender) {
  const Bytes old_msg = pattern(100'000), new_msg = Bytes(100'000, 3);
  const std::size_t step = 60'000;
  Reader r;
  EXPECT_EQ(r.feed(fragment("X", old_msg, 1, 0, 2, step)), "");
  EXPECT_EQ(r.feed(fragment("X", new_msg, 2, 0, 2, step)), "");
  EXPECT_EQ(r.datagrams.dropped_partial(), 1);
  EXPECT_NE(r.feed(fragment("X", old_msg, 1, 1, 2, step)), "");  // the old one's last fragment: no message to join
  EXPECT_TRUE(r.got.empty());
  EXPECT_EQ(r.feed(fragment("X", new_msg, 2, 0, 2, step)), "");
  EXPECT_EQ(r.feed(fragment("X", new_msg, 2, 1, 2, step)), "");
  ASSERT_EQ(r.got.size(), 1u);
  EXPECT_EQ(r.got[0].payload, new_msg);
}

TEST(LcmDatagrams, UnfinishedMessagesOfManySendersStayWithinTheBudgetAndTheNextMessageStillArrives) {
  // Forged first fragments of 10 MB messages from 100 senders: never more than the budget held.
  Reader r;
  Bytes head;
  put32(head, 0x4c433033);
  put32(head, 1);
  put32(head, 10u << 20);
  put32(head, 0);
  put16(head, 0);
  put16(head, 200);
  head.insert(head.end(), {'F', 0, 1, 2, 3});
  for (std::uint64_t sender = 0; sender < 100; ++sender) {
    EXPECT_EQ(r.feed(head, sender, 1000 + static_cast<std::int64_t>(sender) * 10'000), "");  // at the rate taken
    EXPECT_LE(r.datagrams.partial_bytes(), LcmDatagrams::kMaxPartialBytes);
  }
  EXPECT_GE(r.datagrams.dropped_partial(), 90);
  EXPECT_TRUE(r.got.empty());
  const Bytes payload = pattern(100'000);
  EXPECT_EQ(r.feed(fragment("LATER", payload, 3, 0, 2, 60'000), 1000, 2'000'000), "");
  EXPECT_EQ(r.feed(fragment("LATER", payload, 3, 1, 2, 60'000), 1000, 2'000'000), "");
  ASSERT_EQ(r.got.size(), 1u);
  EXPECT_EQ(r.got[0].payload, payload);
}

/// A first fragment that declares `total` bytes for `channel` (sequence number `seqno`).
Bytes first_fragment(const std::string& channel, std::uint32_t total, std::uint32_t seqno) {
  Bytes head;
  put32(head, 0x4c433033);
  put32(head, seqno);
  put32(head, total);
  put32(head, 0);
  put16(head, 0);
  put16(head, 300);
  head.insert(head.end(), channel.begin(), channel.end());
  head.push_back(0);
  head.insert(head.end(), {1, 2, 3, 4});
  return head;
}

// The attack: tiny datagrams that each declare a 16 MB message. Nothing is allocated for a channel
// the node does not read, for more than a read channel's messages can be, for a fragment ahead of
// its first, or beyond the rate of new messages; the node's own messages still arrive.
TEST(LcmDatagrams, AFirstFragmentCostsMemoryOnlyOnAReadChannelWithinItsLimitAndRate) {
  LcmDatagrams d([](std::string_view ch) -> std::size_t { return ch == "ROBOT_SENSORS" ? 65'536 : 0; }, 1u << 20);
  std::vector<std::string> got;
  const auto sink = [&](std::string_view ch, const std::uint8_t*, std::size_t, std::int64_t) { got.emplace_back(ch); };
  const auto feed = [&](const Bytes& b, std::uint64_t sender, std::int64_t utime) { return d.feed(b.data(), b.size(), sender, utime, sink); };
  for (std::uint32_t k = 0; k < 5000; ++k) {
    const std::int64_t t = 1'000'000 + k * 1000;  // 1 kHz
    EXPECT_NE(feed(first_fragment("NOBODY_READS", 16u << 20, k), k, t).find("does not read"), std::string::npos);
    EXPECT_NE(feed(first_fragment("ROBOT_SENSORS", 16u << 20, k), k, t).find("at most 65536 bytes"), std::string::npos);
    Bytes later = fragment("ROBOT_SENSORS", pattern(16u << 10), k, 1, 2, 8u << 10);
    EXPECT_NE(feed(later, k, t).find("before its first"), std::string::npos);
  }
  EXPECT_EQ(d.peak_partial_bytes(), 0u) << "an allocation for a refused message";
  // Within the limit, new messages at a burst: the rate refuses them once the burst is spent, and
  // the budget bounds what the ones taken hold.
  int taken = 0, rate_refused = 0;
  for (std::uint32_t k = 0; k < 1000; ++k) {
    const std::string why = feed(first_fragment("ROBOT_SENSORS", 60'000, k), 100 + k, 10'000'000);
    taken += why.empty() ? 1 : 0;
    rate_refused += why.find("a second") != std::string::npos ? 1 : 0;
  }
  EXPECT_EQ(taken, static_cast<int>(LcmDatagrams::kNewBurst));
  EXPECT_EQ(rate_refused, 1000 - taken);
  EXPECT_LE(d.peak_partial_bytes(), std::size_t{1} << 20);
  // A short message of the node is delivered through all this.
  EXPECT_EQ(feed(short_datagram("ROBOT_SENSORS", {1, 2, 3}), 7, 10'000'001), "");
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], "ROBOT_SENSORS");
}

TEST(LcmDatagrams, MalformedDatagramsAreRefusedWithTheirReasonAndNothingIsDelivered) {
  const Bytes payload = pattern(100'000);
  const auto with = [](Bytes b, std::size_t at, std::uint8_t v) {
    b[at] = v;
    return b;
  };
  const Bytes long_header = fragment("X", payload, 1, 1, 2, 60'000);
  struct Case {
    Bytes datagram;
    std::string reason;
  };
  const std::vector<Case> cases = {
      {{}, "0 bytes, shorter than any LCM header"},
      {Bytes{0x4c, 0x43, 0x30, 0x32, 0, 0, 0}, "7 bytes, shorter than any LCM header"},
      {with(short_datagram("A", {1, 2}), 3, 0x31), "magic 0x4c433031 is not LCM's"},
      {Bytes{0x4c, 0x43, 0x30, 0x32, 0, 0, 0, 1, 'A', 'B'}, "the channel name is not terminated"},
      {short_datagram(std::string(64, 'c'), {1}), "the channel name is longer than 63 bytes"},
      {short_datagram("", {1}), "the channel name is empty"},
      {Bytes(long_header.begin(), long_header.begin() + 19), "fragment of 19 bytes, shorter than its 20-byte header"},
      {with(long_header, 19, 1), "fragment 1 of 1"},
      {with(long_header, 17, 2), "fragment 2 of 2"},
      {with(with(with(with(long_header, 8, 0), 9, 0), 10, 0), 11, 0), "fragmented message of 0 bytes (at most 16777216)"},
      {with(long_header, 8, 0x7f), "fragmented message of 2130806432 bytes (at most 16777216)"},
      {with(long_header, 10, 0), "fragment 1 ends at 100000, beyond the message's 65696 bytes"},
      {with(fragment("X", payload, 1, 0, 2, 60'000), 15, 1), "fragment 0 at offset 1"},
  };
  Reader r;
  for (const auto& c : cases) EXPECT_EQ(r.feed(c.datagram), c.reason);
  EXPECT_TRUE(r.got.empty());
  // And the reader is not left in a state that loses the next good message.
  EXPECT_EQ(r.feed(short_datagram("OK", {9})), "");
  ASSERT_EQ(r.got.size(), 1u);
  EXPECT_EQ(r.got[0].channel, "OK");
}

TEST(UdpmUrl, ParsesGroupPortAndReceiveBufferAndRefusesWhatIsNotAMulticastUrl) {
  const auto u = hpr::node::parse_udpm_url("udpm://239.255.76.99:7699?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(u.group, "239.255.76.99");
  EXPECT_EQ(u.port, 7699);
  EXPECT_EQ(u.recv_buf_size, 4194304);
  const auto d = hpr::node::parse_udpm_url("udpm://");
  EXPECT_EQ(d.group, "239.255.76.67");
  EXPECT_EQ(d.port, 7667);
  EXPECT_EQ(d.recv_buf_size, 0);
  EXPECT_TRUE(hpr::node::is_udpm_url("udpm://239.1.2.3:1"));
  EXPECT_FALSE(hpr::node::is_udpm_url("memq://"));
  const auto refused = [](const std::string& url) {
    try {
      (void)hpr::node::parse_udpm_url(url);
    } catch (const hpr::node::LcmError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(refused("udpm://10.0.0.1:7667"), "LCM URL 'udpm://10.0.0.1:7667': '10.0.0.1' is not an IPv4 multicast address");
  EXPECT_EQ(refused("udpm://239.255.76.67:76x7"), "LCM URL 'udpm://239.255.76.67:76x7': the port '76x7' is not a number in [1, 65535]");
  EXPECT_EQ(refused("udpm://239.255.76.67:7667?recv_buf_size=-1"),
            "LCM URL 'udpm://239.255.76.67:7667?recv_buf_size=-1': recv_buf_size '-1' is not a number in [0, 1073741824]");
  EXPECT_EQ(refused("memq://"), "LCM URL 'memq://' is not a udpm:// URL");
}

}  // namespace
