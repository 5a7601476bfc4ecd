// The viewer process over its real sockets: the Foxglove WebSocket protocol (handshake, channel
// advertisement, subscription, a decoded message equal to the logged one), the refusal of other
// subprotocols, malformed LCM messages skipped with one logged line, and a slow client that loses
// messages without holding up the viewer or other clients.
#include <gtest/gtest.h>

#include <humanoid/robot_state_t.hpp>

#include <array>
#include <cmath>
#include <nlohmann/json.hpp>
#include <thread>

#include "lcm_listener.hpp"
#include "process_group.hpp"
#include "viewer_support.hpp"
#include "ws_client.hpp"

namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using hpr::test::WsClient;

/// The logged joint angle of joint j at tick k.
double q_of(std::int64_t k, std::size_t j) { return 0.3 * std::sin(1e-3 * static_cast<double>(k) + 0.5 * static_cast<double>(j)); }

humanoid::robot_state_t state_at(std::int64_t k, int joints = 3) {
  humanoid::robot_state_t m{};
  m.tick = k;
  m.utime = 5'000'000 + 1000 * k;
  m.quat_WB[0] = 1.0;
  m.p_WB[2] = 0.9;
  m.num_joints = joints;
  static const std::array<const char*, 3> kToro{"l_hip_roll", "l_hip_pitch", "l_hip_yaw"};
  for (int j = 0; j < joints; ++j) {
    std::string name = j < 3 ? kToro[static_cast<std::size_t>(j)] : "j";
    if (j >= 3) name += std::to_string(j);
    m.joint_name.push_back(name);
    m.q.push_back(q_of(k, static_cast<std::size_t>(j)));
  }
  m.qd = m.tau = std::vector<double>(static_cast<std::size_t>(joints), 0.0);
  return m;
}

std::string config() { return hpr::test::source_dir() + "/config/toro.yaml"; }

/// Reads frames until one satisfies `pred` or the timeout; returns it (opcode -1 if none).
template <class Pred>
WsClient::Frame read_until(WsClient& ws, Pred pred, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    auto f = ws.read(200);
    if (f.opcode >= 0 && pred(f)) return f;
  }
  return {};
}

std::uint32_t sub_id(const std::string& p) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(p[1])) | static_cast<std::uint32_t>(static_cast<unsigned char>(p[2])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(p[3])) << 16 | static_cast<std::uint32_t>(static_cast<unsigned char>(p[4])) << 24;
}

/// Subscribes `id` to the advertised channel `topic`; returns false when it is not advertised.
bool subscribe(WsClient& ws, const json& advertise, const std::string& topic, int id) {
  for (const auto& c : advertise["channels"]) {
    if (c["topic"] == topic) {
      ws.send_text(json{{"op", "subscribe"}, {"subscriptions", {{{"id", id}, {"channelId", c["id"]}}}}}.dump());
      return true;
    }
  }
  return false;
}

TEST(ViewerNode, FoxgloveHandshakeAdvertisementAndADecodedMessageFromALog) {
  const std::string dir = hpr::test::temp_dir("viewer_foxglove");
  {
    hpr::test::LogWriter log(dir + "/run.lcm");
    for (std::int64_t k = 0; k < 3000; ++k) log.write("ROBOT_STATE", state_at(k), 1000 * k);
  }
  hpr::test::ProcessGroup group;
  const int port = hpr::test::start_viewer(
      group, {"--config", config(), "--set", "viewer.port=0", "--set", "viewer.log=" + dir + "/run.lcm"}, dir + "/viewer.log");
  ASSERT_GT(port, 0) << hpr::test::read_text(dir + "/viewer.log");

  WsClient ws(port, "foxglove.websocket.v1");
  ASSERT_TRUE(ws.upgraded()) << ws.response();
  EXPECT_NE(ws.response().find("Sec-WebSocket-Protocol: foxglove.websocket.v1"), std::string::npos) << ws.response();
  const auto hello = ws.read();
  ASSERT_EQ(hello.opcode, 1) << "serverInfo is a text frame";
  const json info = json::parse(hello.payload);
  EXPECT_EQ(info["op"], "serverInfo");
  EXPECT_EQ(info["metadata"]["mode"], "log");
  EXPECT_EQ(info["metadata"]["robot"], "toro");
  const auto adv = ws.read();
  ASSERT_EQ(adv.opcode, 1);
  const json advertise = json::parse(adv.payload);
  ASSERT_EQ(advertise["op"], "advertise");
  for (const auto& c : advertise["channels"]) {
    EXPECT_EQ(c["encoding"], "json");
    EXPECT_EQ(c["schemaEncoding"], "jsonschema");
    EXPECT_TRUE(json::parse(c["schema"].get<std::string>()).is_object()) << c["topic"];
  }

  ASSERT_TRUE(subscribe(ws, advertise, "ROBOT_STATE", 7));
  const auto msg = read_until(ws, [](const WsClient::Frame& f) { return f.opcode == 2; }, 5s);
  ASSERT_EQ(msg.opcode, 2) << "no message data after subscribing";
  ASSERT_GE(msg.payload.size(), 13U);
  EXPECT_EQ(static_cast<unsigned char>(msg.payload[0]), 0x01) << "message data opcode";
  EXPECT_EQ(sub_id(msg.payload), 7U) << "our subscription id";
  const json m = json::parse(msg.payload.substr(13));
  const auto k = m["tick"].get<std::int64_t>();
  ASSERT_EQ(m["q"].size(), 3U);
  for (std::size_t j = 0; j < 3; ++j) EXPECT_EQ(m["q"][j].get<double>(), q_of(k, j)) << "tick " << k << " joint " << j;
  EXPECT_EQ(m["utime"].get<std::int64_t>(), 5'000'000 + 1000 * k);

  // A subscription to a channel that does not exist gets a warning status, and the session goes on.
  ws.send_text(R"({"op":"subscribe","subscriptions":[{"id":8,"channelId":99}]})");
  const auto status = read_until(ws, [](const WsClient::Frame& f) { return f.opcode == 1; }, 5s);
  ASSERT_EQ(status.opcode, 1);
  const json st = json::parse(status.payload);
  EXPECT_EQ(st["op"], "status");
  EXPECT_EQ(st["level"], 1);
  EXPECT_NE(st["message"].get<std::string>().find("99"), std::string::npos) << st.dump();
  EXPECT_EQ(read_until(ws, [](const WsClient::Frame& f) { return f.opcode == 2; }, 5s).opcode, 2);

  // The page's routes.
  const json summary = json::parse(hpr::test::http_body(hpr::test::http_get(port, "/api/log")));
  EXPECT_NEAR(summary["duration"].get<double>(), 2.999, 1e-9);
  EXPECT_NE(hpr::test::http_get(port, "/").find("<script type=\"module\" src=\"/app/viewer.js\">"), std::string::npos);
  EXPECT_NE(hpr::test::http_get(port, "/robot/robot.urdf").find("<robot name=\"toro\">"), std::string::npos);
  EXPECT_EQ(hpr::test::http_get(port, "/app/../../CMakeLists.txt").rfind("HTTP/1.1 404", 0), 0U) << "nothing outside the page's folder";
  EXPECT_EQ(hpr::test::http_get(port, "/api/frame/100000").rfind("HTTP/1.1 404", 0), 0U);
}

TEST(ViewerNode, ALogOfAnotherRobotIsRefusedNamingAJointAndTheFix) {
  const std::string dir = hpr::test::temp_dir("viewer_other_robot");
  {
    hpr::test::LogWriter log(dir + "/run.lcm");
    for (std::int64_t k = 0; k < 10; ++k) log.write("ROBOT_STATE", state_at(k), 1000 * k);  // TORO's joints
  }
  hpr::test::ProcessGroup group;
  const pid_t pid = group.start("viewer",
                                {"--config", hpr::test::source_dir() + "/config/h1_2.yaml", "--set", "viewer.port=0", "--set",
                                 "viewer.log=" + dir + "/run.lcm"},
                                {}, dir + "/viewer.log");
  const auto r = group.wait(pid, 30s);
  const std::string out = hpr::test::read_text(dir + "/viewer.log");
  EXPECT_TRUE(r.exited && r.exit_code != 0) << out;
  EXPECT_NE(out.find("l_hip_roll"), std::string::npos) << out;
  EXPECT_NE(out.find("--robot"), std::string::npos) << out;
}

TEST(ViewerNode, RefusesAWebSocketWithoutTheFoxgloveSubprotocol) {
  const std::string dir = hpr::test::temp_dir("viewer_subprotocol");
  hpr::test::ProcessGroup group;
  const int port = hpr::test::start_viewer(group, {"--config", config(), "--set", "viewer.port=0"}, dir + "/viewer.log");
  ASSERT_GT(port, 0) << hpr::test::read_text(dir + "/viewer.log");
  WsClient plain(port, "");
  EXPECT_FALSE(plain.upgraded()) << plain.response();
  EXPECT_EQ(plain.response().rfind("HTTP/1.1 400", 0), 0U) << plain.response();
  WsClient other(port, "some.other.protocol");
  EXPECT_FALSE(other.upgraded()) << other.response();
}

TEST(ViewerNode, LiveMalformedMessagesAreSkippedWithOneLogLineAndCounted) {
  const std::string dir = hpr::test::temp_dir("viewer_live");
  hpr::test::ProcessGroup group;
  hpr::test::LcmListener lcm(group.lcm_url());
  const int port = hpr::test::start_viewer(group, {"--config", config(), "--set", "viewer.port=0"}, dir + "/viewer.log");
  ASSERT_GT(port, 0) << hpr::test::read_text(dir + "/viewer.log");
  WsClient ws(port, "foxglove.websocket.v1");
  ASSERT_TRUE(ws.upgraded());
  (void)ws.read();
  const json advertise = json::parse(ws.read().payload);
  ASSERT_TRUE(subscribe(ws, advertise, "ROBOT_STATE", 1));
  std::this_thread::sleep_for(200ms);

  const std::uint8_t garbage[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
  // The viewer decodes the latest message of a channel at the display rate (30 Hz): five malformed
  // ones, 100 ms apart, are five decode errors.
  for (int i = 0; i < 5; ++i) {
    lcm.lcm().publish("ROBOT_STATE", garbage, sizeof garbage);
    lcm.spin_for(100ms);
  }
  for (std::int64_t k = 1; k <= 50; ++k) {
    lcm.publish("ROBOT_STATE", state_at(k));
    lcm.spin_for(2ms);
  }
  const auto msg = read_until(ws, [](const WsClient::Frame& f) { return f.opcode == 2; }, 5s);
  ASSERT_EQ(msg.opcode, 2) << hpr::test::read_text(dir + "/viewer.log");
  const json m = json::parse(msg.payload.substr(13));
  const auto k = m["tick"].get<std::int64_t>();
  EXPECT_EQ(m["q"][1].get<double>(), q_of(k, 1));

  std::this_thread::sleep_for(1200ms);  // the status counters refresh every second
  const json status = json::parse(hpr::test::http_body(hpr::test::http_get(port, "/api/status")));
  EXPECT_EQ(status["decode_errors"].get<int>(), 5) << status.dump();
  const std::string out = hpr::test::read_text(dir + "/viewer.log");
  std::size_t lines = 0;
  for (std::size_t p = out.find("skipped: ROBOT_STATE"); p != std::string::npos; p = out.find("skipped: ROBOT_STATE", p + 1)) ++lines;
  EXPECT_EQ(lines, 1U) << "one line per channel, not one per message:\n" << out;
}

TEST(ViewerNode, ASlowClientLosesMessagesWithoutHoldingUpTheViewerOrOtherClients) {
  const std::string dir = hpr::test::temp_dir("viewer_slow");
  hpr::test::ProcessGroup group;
  hpr::test::LcmListener lcm(group.lcm_url());
  const int port = hpr::test::start_viewer(
      group, {"--config", config(), "--set", "viewer.port=0", "--set", "viewer.rate_hz=120", "--set", "viewer.max_client_buffer_kb=16"},
      dir + "/viewer.log");
  ASSERT_GT(port, 0) << hpr::test::read_text(dir + "/viewer.log");
  // The slow client: a 4 kB receive window, and it never reads after subscribing.
  WsClient slow(port, "foxglove.websocket.v1", 4096);
  ASSERT_TRUE(slow.upgraded());
  (void)slow.read();
  ASSERT_TRUE(subscribe(slow, json::parse(slow.read().payload), "ROBOT_STATE", 1));
  WsClient fast(port, "foxglove.websocket.v1");
  ASSERT_TRUE(fast.upgraded());
  (void)fast.read();
  ASSERT_TRUE(subscribe(fast, json::parse(fast.read().payload), "ROBOT_STATE", 1));

  std::atomic<bool> stop{false};
  std::thread publisher([&] {
    hpr::test::LcmListener pub(group.lcm_url());
    for (std::int64_t k = 0; !stop; ++k) {
      pub.publish("ROBOT_STATE", state_at(k, 300));  // about 10 kB as JSON
      std::this_thread::sleep_for(1ms);
    }
  });
  int received = 0;
  std::int64_t last_tick = -1;
  const auto end = std::chrono::steady_clock::now() + 4s;
  while (std::chrono::steady_clock::now() < end) {
    const auto f = fast.read(500);
    if (f.opcode != 2) continue;
    ++received;
    last_tick = json::parse(f.payload.substr(13))["tick"].get<std::int64_t>();
  }
  stop = true;
  publisher.join();
  std::this_thread::sleep_for(1200ms);
  const json status = json::parse(hpr::test::http_body(hpr::test::http_get(port, "/api/status")));
  EXPECT_GT(status["dropped"].get<int>(), 0) << "the slow client's messages are dropped: " << status.dump();
  EXPECT_GT(received, 100) << "the other client keeps receiving (about 120 a second)";
  EXPECT_GT(last_tick, 1000) << "and what it receives is current";
}

}  // namespace
