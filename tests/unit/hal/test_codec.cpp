// The wire formats: MIT frames round-trip every field over its range within half a quantisation
// step and saturate out of range; cannelloni datagrams round-trip and malformed ones are refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>

#include <cmath>
#include <cstring>
#include <random>

#include "hpr/hal/cannelloni.hpp"
#include "hpr/hal/mit_codec.hpp"

namespace {

using namespace hpr::hal;

double step(double lo, double hi, int bits) { return (hi - lo) / static_cast<double>((1U << bits) - 1U); }

TEST(MitCodec, CommandFieldsRoundTripWithinHalfAStepOverTheirWholeRange) {
  const MitCodec codec;
  const DriveLimits l{-3.0, 2.0, -20.0, 30.0, 0.0, 800.0, 0.0, 40.0, -150.0, 120.0};
  double worst[5] = {0, 0, 0, 0, 0};
  for (int k = 0; k <= 4000; ++k) {
    const double s = k / 4000.0;
    DriveCommand c{l.p_min + s * (l.p_max - l.p_min), l.v_min + s * (l.v_max - l.v_min), l.kp_max * s, l.kd_max * (1 - s),
                   l.t_min + (1 - s) * (l.t_max - l.t_min)};
    const CanFrame f = codec.encode_command(17, c, l);
    ASSERT_EQ(f.id, 17U);
    ASSERT_EQ(f.len, 8);
    const auto r = codec.decode_request(f, l);
    ASSERT_TRUE(r && r->command && !r->special);
    EXPECT_EQ(r->drive_id, 17);
    worst[0] = std::max(worst[0], std::abs(r->command->p_des - c.p_des));
    worst[1] = std::max(worst[1], std::abs(r->command->v_des - c.v_des));
    worst[2] = std::max(worst[2], std::abs(r->command->kp - c.kp));
    worst[3] = std::max(worst[3], std::abs(r->command->kd - c.kd));
    worst[4] = std::max(worst[4], std::abs(r->command->t_ff - c.t_ff));
  }
  EXPECT_LE(worst[0], 0.5 * step(l.p_min, l.p_max, 16) + 1e-12);
  EXPECT_LE(worst[1], 0.5 * step(l.v_min, l.v_max, 12) + 1e-12);
  EXPECT_LE(worst[2], 0.5 * step(0, l.kp_max, 12) + 1e-12);
  EXPECT_LE(worst[3], 0.5 * step(0, l.kd_max, 12) + 1e-12);
  EXPECT_LE(worst[4], 0.5 * step(l.t_min, l.t_max, 12) + 1e-12);
  // The extremes are exact.
  const auto top = codec.decode_request(codec.encode_command(1, {l.p_max, l.v_max, l.kp_max, l.kd_max, l.t_max}, l), l);
  EXPECT_DOUBLE_EQ(top->command->p_des, l.p_max);
  EXPECT_DOUBLE_EQ(top->command->t_ff, l.t_max);
}

TEST(MitCodec, ReplyRoundTripsAndCarriesFaultAndTemperature) {
  const MitCodec codec;
  const DriveLimits l;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 2000; ++k) {
    DriveReply r;
    r.drive_id = 1 + k % 127;
    r.p = l.p_min + u(rng) * (l.p_max - l.p_min);
    r.v = l.v_min + u(rng) * (l.v_max - l.v_min);
    r.t = l.t_min + u(rng) * (l.t_max - l.t_min);
    r.fault = static_cast<std::uint8_t>(k % 256);
    r.temperature = -40.0 + k % 200;
    const CanFrame f = codec.encode_reply(r, l);
    EXPECT_EQ(f.id, MitCodec::kReplyBase + static_cast<std::uint32_t>(r.drive_id));
    const auto d = codec.decode_reply(f, l);
    ASSERT_TRUE(d);
    EXPECT_EQ(d->drive_id, r.drive_id);
    EXPECT_LE(std::abs(d->p - r.p), 0.5 * step(l.p_min, l.p_max, 16) + 1e-12);
    EXPECT_LE(std::abs(d->v - r.v), 0.5 * step(l.v_min, l.v_max, 12) + 1e-12);
    EXPECT_LE(std::abs(d->t - r.t), 0.5 * step(l.t_min, l.t_max, 12) + 1e-12);
    EXPECT_EQ(d->fault, r.fault);
    EXPECT_DOUBLE_EQ(d->temperature, r.temperature);
  }
}

TEST(MitCodec, OutOfRangeSaturatesAndSpecialFramesAreRecognised) {
  const MitCodec codec;
  const DriveLimits l;
  const auto r = codec.decode_request(codec.encode_command(3, {100.0, -1e3, 1e6, -5.0, 1e9}, l), l);
  EXPECT_DOUBLE_EQ(r->command->p_des, l.p_max);
  EXPECT_DOUBLE_EQ(r->command->v_des, l.v_min);
  EXPECT_DOUBLE_EQ(r->command->kp, l.kp_max);
  EXPECT_DOUBLE_EQ(r->command->kd, 0.0);
  EXPECT_DOUBLE_EQ(r->command->t_ff, l.t_max);
  for (const auto s : {SpecialCommand::kEnterMotorMode, SpecialCommand::kExitMotorMode, SpecialCommand::kZeroEncoder}) {
    const auto q = codec.decode_request(codec.encode_special(9, s), l);
    ASSERT_TRUE(q && q->special);
    EXPECT_EQ(*q->special, s);
  }
}

TEST(MitCodec, MalformedFramesAreRefused) {
  const MitCodec codec;
  const DriveLimits l;
  CanFrame f = codec.encode_reply(DriveReply{5, 0.1, 0.2, 0.3, 0, 30}, l);
  f.len = 6;
  EXPECT_FALSE(codec.decode_reply(f, l)) << "wrong length";
  f = codec.encode_reply(DriveReply{5, 0.1, 0.2, 0.3, 0, 30}, l);
  f.data[0] = 6;
  EXPECT_FALSE(codec.decode_reply(f, l)) << "id byte disagrees with the identifier";
  f = codec.encode_reply(DriveReply{5, 0.1, 0.2, 0.3, 0, 30}, l);
  f.id |= kCanErrFlag;
  EXPECT_FALSE(codec.decode_reply(f, l)) << "error frame";
  CanFrame c = codec.encode_command(0x200, {}, l);
  EXPECT_FALSE(codec.decode_request(c, l)) << "id beyond the drive range";
}

TEST(SensorFrames, Int16FieldsRoundTripAndSaturate) {
  const double v[3] = {12.345, -0.002, 1e9};
  double back[3];
  ASSERT_TRUE(decode_int16s(encode_int16s(kFtForceId, v, 3, kFtForceScale), back, 3, kFtForceScale));
  EXPECT_NEAR(back[0], v[0], 0.5 * kFtForceScale);
  EXPECT_NEAR(back[1], v[1], 0.5 * kFtForceScale);
  EXPECT_DOUBLE_EQ(back[2], 32767 * kFtForceScale);
  CanFrame shorter = encode_int16s(kImuGyroId, v, 3, kImuGyroScale);
  shorter.len = 5;
  EXPECT_FALSE(decode_int16s(shorter, back, 3, kImuGyroScale));
}

TEST(SensorFrames, LockstepClockFrameCarriesTheTickExactly) {
  for (const std::int64_t tick : {std::int64_t{0}, std::int64_t{1}, std::int64_t{1234567}, std::int64_t{-1}, INT64_MAX, INT64_MIN}) {
    const CanFrame f = encode_lockstep_tick(tick);
    EXPECT_EQ(f.id, kLockstepTickId);
    EXPECT_EQ(f.len, 8);
    const auto back = decode_lockstep_tick(f);
    ASSERT_TRUE(back.has_value()) << tick;
    EXPECT_EQ(*back, tick);
  }
  CanFrame shorter = encode_lockstep_tick(7);
  shorter.len = 4;
  EXPECT_FALSE(decode_lockstep_tick(shorter).has_value());
}

TEST(Cannelloni, DatagramsRoundTripClassicAndFdFramesBitExactly) {
  std::vector<CanFrame> frames;
  std::mt19937 rng(7);
  for (int k = 0; k < 40; ++k) {
    CanFrame f;
    f.fd = k % 3 == 0;
    f.id = (k % 5 == 0) ? (kCanEffFlag | static_cast<std::uint32_t>(rng() & 0x1FFFFFFF)) : static_cast<std::uint32_t>(rng() & 0x7FF);
    f.len = f.fd ? fd_length(static_cast<std::uint8_t>(rng() % 65)) : static_cast<std::uint8_t>(rng() % 9);
    f.flags = f.fd ? 1 : 0;
    for (int i = 0; i < f.len; ++i) f.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(rng());
    frames.push_back(f);
  }
  std::vector<std::uint8_t> buf(4096);
  const std::size_t n = cannelloni_encode(frames, 42, buf);
  ASSERT_GT(n, 5U);
  EXPECT_EQ(buf[0], 2);
  EXPECT_EQ(buf[1], 0);
  EXPECT_EQ(buf[2], 42);
  EXPECT_EQ((buf[3] << 8) | buf[4], 40);
  std::vector<CanFrame> back;
  ASSERT_EQ(cannelloni_decode(std::span<const std::uint8_t>(buf.data(), n), back), "");
  ASSERT_EQ(back.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(back[i].id, frames[i].id);
    EXPECT_EQ(back[i].len, frames[i].len);
    EXPECT_EQ(back[i].fd, frames[i].fd);
    EXPECT_EQ(0, std::memcmp(back[i].data.data(), frames[i].data.data(), frames[i].len));
  }
  // Big-endian identifier of the first frame right after the header.
  EXPECT_EQ((static_cast<std::uint32_t>(buf[5]) << 24 | static_cast<std::uint32_t>(buf[6]) << 16 |
             static_cast<std::uint32_t>(buf[7]) << 8 | buf[8]),
            frames[0].id);
}

// The attack: a datagram with a valid frame sent to the hal's port from another address or port than
// the bus's configured peer (a forged reply, a forged bus-off error frame) is refused and counted.
TEST(Cannelloni, ADatagramFromAnotherThanThePeerIsRefused) {
  const int hal_port = 47311, peer_port = 47312, stranger_port = 47313;
  UdpCannelloniTransport hal("can0", {"127.0.0.1", hal_port}, {"127.0.0.1", peer_port});
  UdpCannelloniTransport peer("can0", {"127.0.0.1", peer_port}, {"127.0.0.1", hal_port});
  UdpCannelloniTransport stranger("can0", {"127.0.0.1", stranger_port}, {"127.0.0.1", hal_port});
  CanFrame reply;
  reply.id = 0x101;
  reply.len = 8;
  CanFrame bus_off;
  bus_off.id = kCanErrFlag | kCanErrBusOff;
  bus_off.len = 8;
  stranger.send(reply);
  stranger.send(bus_off);
  stranger.flush();
  peer.send(reply);
  peer.flush();
  std::vector<CanFrame> got;
  for (int k = 0; k < 200 && got.empty(); ++k) {
    hal.receive(got);
    if (got.empty()) ::usleep(1000);
  }
  ::usleep(20000);
  hal.receive(got);
  ASSERT_EQ(got.size(), 1U) << "the peer's frame, and only it";
  EXPECT_EQ(got[0].id, 0x101U);
  EXPECT_EQ(hal.counters().foreign, 1);
  EXPECT_FALSE(hal.counters().bus_off) << "a stranger's error frame set bus-off";
  EXPECT_NE(hal.counters().last_error.find("refused: the bus's peer is 127.0.0.1:47312"), std::string::npos) << hal.counters().last_error;
}

TEST(Cannelloni, MalformedDatagramsAreRefusedWholeAndSayWhy) {
  std::vector<CanFrame> frames(3);
  for (auto& f : frames) f.len = 8;
  std::vector<std::uint8_t> buf(256);
  const std::size_t n = cannelloni_encode(frames, 0, buf);
  std::vector<CanFrame> out;
  EXPECT_NE(cannelloni_decode(std::span<const std::uint8_t>(buf.data(), n - 1), out), "");
  EXPECT_TRUE(out.empty()) << "nothing of a truncated datagram is kept";
  buf[0] = 1;
  EXPECT_NE(cannelloni_decode(std::span<const std::uint8_t>(buf.data(), n), out).find("version"), std::string::npos);
  buf[0] = 2;
  buf[9] = 9;  // classic frame of 9 bytes
  EXPECT_NE(cannelloni_decode(std::span<const std::uint8_t>(buf.data(), n), out).find("length"), std::string::npos);
  EXPECT_NE(cannelloni_decode(std::span<const std::uint8_t>(buf.data(), 3), out), "");
  EXPECT_TRUE(out.empty());
  EXPECT_THROW(UdpEndpoint::parse("localhost"), std::invalid_argument);
  EXPECT_THROW(UdpEndpoint::parse("1.2.3.4:70000"), std::invalid_argument);
  EXPECT_EQ(UdpEndpoint::parse("10.0.0.2:21001").port, 21001);
}

}  // namespace
