// The viewer library: JSON conversion against the messages and their schemas, the Foxglove wire
// format byte by byte, the display URDF against the loaded description, and log frames.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "all_types.hpp"
#include "hpr/model/urdf.hpp"
#include "hpr/viewer/channels.hpp"
#include "hpr/viewer/display_robot.hpp"
#include "hpr/viewer/foxglove.hpp"
#include "hpr/viewer/timeline.hpp"
#include "model_fixture.hpp"

namespace {

using namespace hpr;
using nlohmann::json;

/// An independent check of a value against the subset of JSON schema the viewer writes: returns
/// the first mismatch ("" when none).
std::string validate(const json& v, const json& schema, const std::string& at = "$") {
  const json& type = schema.at("type");
  auto allows = [&type](const char* t) {
    if (type.is_string()) return type == t;
    for (const auto& x : type) {
      if (x == t) return true;
    }
    return false;
  };
  if (v.is_null()) return allows("null") ? "" : at + ": null not allowed";
  if (v.is_object()) {
    if (!allows("object")) return at + ": object not allowed";
    for (const auto& r : schema.at("required")) {
      if (!v.contains(r.get<std::string>())) return at + ": missing " + r.get<std::string>();
    }
    for (const auto& [k, x] : v.items()) {
      if (!schema.at("properties").contains(k)) return at + ": unexpected " + k;
      if (auto e = validate(x, schema.at("properties").at(k), at + "." + k); !e.empty()) return e;
    }
    return "";
  }
  if (v.is_array()) {
    if (!allows("array")) return at + ": array not allowed";
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (auto e = validate(v[i], schema.at("items"), at + "[" + std::to_string(i) + "]"); !e.empty()) return e;
    }
    return "";
  }
  if (v.is_boolean()) return allows("boolean") ? "" : at + ": boolean not allowed";
  if (v.is_number_integer()) return allows("integer") || allows("number") ? "" : at + ": integer not allowed";
  if (v.is_number_float()) return allows("number") ? "" : at + ": number not allowed";
  if (v.is_string()) return allows("string") ? "" : at + ": string not allowed";
  return at + ": unexpected JSON type";
}

TEST(ViewerChannels, EveryShownChannelDecodesIntoJsonThatItsSchemaAccepts) {
  test::Filler fill(7);
  int checked = 0;
  test::for_each_type([&]<class Msg>(const char* name) {
    if (viewer::channel_index(name) < 0) return;
    Msg m{};
    fill.fill(m);
    const auto bytes = test::encode(m);
    const auto d = viewer::decode(name, bytes.data(), bytes.size());
    const auto& info = viewer::channels()[static_cast<std::size_t>(viewer::channel_index(name))];
    EXPECT_EQ(validate(d.json, info.schema), "") << name;
    EXPECT_EQ(d.tick, m.tick) << name;
    EXPECT_EQ(d.utime, m.utime) << name;
    EXPECT_EQ(info.schema_name, std::string("humanoid.") + Msg::getTypeName());
    ++checked;
  });
  EXPECT_EQ(checked, static_cast<int>(viewer::channels().size())) << "every shown channel is a type of the stack";
}

TEST(ViewerChannels, NumbersSurviveTheTextExactly) {
  test::Filler fill(11, 29);
  humanoid::robot_state_t m{};
  fill.fill(m);
  m.q[3] = std::nextafter(0.1, 1.0);
  m.q[4] = 1e-300;
  m.q[5] = std::nan("");
  m.q[6] = -std::numeric_limits<double>::infinity();
  const auto bytes = test::encode(m);
  const json j = json::parse(viewer::decode("ROBOT_STATE", bytes.data(), bytes.size()).json.dump());
  ASSERT_EQ(j["q"].size(), m.q.size());
  for (std::size_t i = 0; i < m.q.size(); ++i) {
    if (std::isfinite(m.q[i])) {
      EXPECT_EQ(j["q"][i].get<double>(), m.q[i]) << "joint " << i;  // bit for bit, through text
    } else {
      EXPECT_TRUE(j["q"][i].is_null()) << "a non-finite number is null in JSON, joint " << i;
    }
  }
  EXPECT_EQ(j["joint_name"][2].get<std::string>(), m.joint_name[2]);
  EXPECT_EQ(j["foot_contact"][1].get<bool>(), m.foot_contact[1] != 0);
}

TEST(ViewerChannels, MalformedMessagesAndUnknownChannelsAreRefusedByName) {
  test::Filler fill(3);
  humanoid::sim_truth_t m{};
  fill.fill(m);
  auto bytes = test::encode(m);
  bytes.resize(bytes.size() / 2);
  try {
    (void)viewer::decode("SIM_TRUTH", bytes.data(), bytes.size());
    FAIL() << "a truncated message decoded";
  } catch (const viewer::DecodeError& e) {
    EXPECT_NE(std::string(e.what()).find("SIM_TRUTH"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(std::to_string(bytes.size()) + " bytes"), std::string::npos) << e.what();
  }
  // A ROBOT_STATE on the SIM_TRUTH channel: the fingerprint differs.
  humanoid::robot_state_t other{};
  fill.fill(other);
  const auto wrong = test::encode(other);
  EXPECT_THROW((void)viewer::decode("SIM_TRUTH", wrong.data(), wrong.size()), viewer::DecodeError);
  EXPECT_THROW((void)viewer::decode("JOINT_COMMAND", wrong.data(), wrong.size()), viewer::DecodeError);
}

TEST(Foxglove, MessageDataIsOpcodeSubscriptionTimestampPayloadLittleEndian) {
  const std::string f = viewer::foxglove::message_data(0x01020304U, 0x0102030405060708ULL, "{\"a\":1}");
  const unsigned char expected[13] = {0x01, 0x04, 0x03, 0x02, 0x01, 0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01};
  ASSERT_EQ(f.size(), 13U + 7U);
  for (std::size_t i = 0; i < 13; ++i) EXPECT_EQ(static_cast<unsigned char>(f[i]), expected[i]) << "byte " << i;
  EXPECT_EQ(f.substr(13), "{\"a\":1}");
  viewer::foxglove::MessageData d;
  ASSERT_TRUE(viewer::foxglove::parse_message_data(f, d));
  EXPECT_EQ(d.subscription_id, 0x01020304U);
  EXPECT_EQ(d.timestamp_ns, 0x0102030405060708ULL);
  EXPECT_EQ(d.payload, "{\"a\":1}");
  EXPECT_FALSE(viewer::foxglove::parse_message_data(f.substr(0, 12), d));
  std::string other = f;
  other[0] = 0x02;
  EXPECT_FALSE(viewer::foxglove::parse_message_data(other, d));
}

TEST(Foxglove, AdvertiseListsEveryChannelWithItsJsonSchema) {
  const json a = json::parse(viewer::foxglove::advertise(viewer::channels()));
  EXPECT_EQ(a["op"], "advertise");
  ASSERT_EQ(a["channels"].size(), viewer::channels().size());
  for (std::size_t i = 0; i < a["channels"].size(); ++i) {
    const auto& c = a["channels"][i];
    EXPECT_EQ(c["id"].get<std::size_t>(), i + 1);
    EXPECT_EQ(c["topic"], viewer::channels()[i].name);
    EXPECT_EQ(c["encoding"], "json");
    EXPECT_EQ(c["schemaEncoding"], "jsonschema");
    EXPECT_EQ(json::parse(c["schema"].get<std::string>()), viewer::channels()[i].schema) << "the schema is a JSON string";
  }
  const json info = json::parse(viewer::foxglove::server_info("x", {{"robot", "toro"}}, "s1"));
  EXPECT_EQ(info["op"], "serverInfo");
  EXPECT_EQ(info["metadata"]["robot"], "toro");
  EXPECT_EQ(info["supportedEncodings"][0], "json");
}

TEST(Foxglove, SubscriptionsApplyValidPartsAndNameWhatIsWrong) {
  viewer::foxglove::Subscriptions s;
  EXPECT_EQ(s.apply(R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":1},{"id":2,"channelId":3}]})", 7), "");
  EXPECT_EQ(s.size(), 2U);
  EXPECT_EQ(s.of_channel(1), std::vector<std::uint32_t>{1});
  EXPECT_EQ(s.of_channel(3), std::vector<std::uint32_t>{2});
  const std::string e = s.apply(R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":2},{"id":5,"channelId":99},{"id":6,"channelId":2}]})", 7);
  EXPECT_NE(e.find("subscription id 1 is already in use"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown channel id 99"), std::string::npos) << e;
  EXPECT_EQ(s.of_channel(2), std::vector<std::uint32_t>{6}) << "the valid part applied";
  EXPECT_EQ(s.apply(R"({"op":"unsubscribe","subscriptionIds":[1, 42]})", 7), "unsubscribe: 42 is not a subscription");
  EXPECT_TRUE(s.of_channel(1).empty());
  EXPECT_EQ(s.apply("{nope", 7), "not a JSON object");
  EXPECT_NE(s.apply(R"({"op":"advertise"})", 7).find("not supported"), std::string::npos);
  EXPECT_EQ(s.apply(R"({"subscriptions":[]})", 7), "no \"op\"");
  EXPECT_NE(s.apply(R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]})", 7).find("unsigned"), std::string::npos);
}

TEST(DisplayRobot, RollPitchYawRebuildsTheRotation) {
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> u(-1, 1);
  auto compose = [](const model::Vector3d& rpy) {
    return model::Matrix3d(Eigen::AngleAxisd(rpy.z(), model::Vector3d::UnitZ()) * Eigen::AngleAxisd(rpy.y(), model::Vector3d::UnitY()) *
                           Eigen::AngleAxisd(rpy.x(), model::Vector3d::UnitX()));
  };
  for (int k = 0; k < 200; ++k) {
    const model::Matrix3d R = Eigen::Quaterniond(u(gen), u(gen), u(gen), u(gen)).normalized().toRotationMatrix();
    EXPECT_LT((compose(viewer::rpy_of(R)) - R).norm(), 1e-12);
  }
  for (double pitch : {M_PI / 2, -M_PI / 2}) {
    const model::Matrix3d R = compose({0.3, pitch, -0.7});
    EXPECT_LT((compose(viewer::rpy_of(R)) - R).norm(), 1e-12) << "gimbal lock at pitch " << pitch;
  }
}

/// The display URDF, read back by the stack's own loader, has the loaded description's tree.
void expect_same_tree(const std::string& robot) {
  const auto spec = test::load_robot(robot);
  const auto d = viewer::display_robot(spec);
  model::UrdfOptions opt;
  opt.resolve_meshes = false;
  const auto back = model::parse_urdf(d.urdf, "display URDF of " + robot, opt);
  const auto& a = spec.description;
  ASSERT_EQ(back.joints.size(), a.joints.size());
  for (std::size_t i = 0; i < a.joints.size(); ++i) {
    const auto& x = a.joints[i];
    const auto* y = back.find_joint(x.name);
    ASSERT_NE(y, nullptr) << x.name;
    EXPECT_EQ(y->type, x.type) << x.name;
    EXPECT_EQ(y->parent, x.parent) << x.name;
    EXPECT_EQ(y->child, x.child) << x.name;
    EXPECT_LT((y->X_PJ.R - x.X_PJ.R).norm(), 1e-12) << x.name;
    EXPECT_LT((y->X_PJ.p - x.X_PJ.p).norm(), 1e-15) << x.name;
    EXPECT_LT((y->axis - x.axis).norm(), 1e-15) << x.name;
    EXPECT_EQ(y->mimic, x.mimic) << x.name;
    if (x.has_limits && x.type == model::JointType::kRevolute) {
      EXPECT_EQ(y->lower, x.lower) << x.name;
      EXPECT_EQ(y->upper, x.upper) << x.name;
    }
  }
  std::size_t meshes = 0, inertia_boxes = 0;
  for (const auto& link : a.links) {
    const auto* l = back.find_link(link.name);
    ASSERT_NE(l, nullptr) << link.name;
    const auto& shown = link.visuals.empty() ? link.collisions : link.visuals;
    if (shown.empty() && link.mass > 0) {
      // No geometry at all: one box whose uniform-density inertia is the link's.
      ASSERT_EQ(l->visuals.size(), 1U) << link.name;
      const auto& box = l->visuals[0];
      ASSERT_EQ(box.type, model::Geometry::Type::kBox) << link.name;
      const model::Vector3d& a2 = box.size.cwiseProduct(box.size);
      const model::Matrix3d I_G = (link.mass / 12.0) * model::Vector3d(a2.y() + a2.z(), a2.x() + a2.z(), a2.x() + a2.y()).asDiagonal();
      const model::Matrix3d I_L = box.X_LG.R * I_G * box.X_LG.R.transpose();
      EXPECT_LT((I_L - link.inertia_physical).norm(), 1e-9 * link.inertia_physical.norm()) << link.name;
      EXPECT_LT((box.X_LG.p - link.com).norm(), 1e-12) << link.name;
      ++inertia_boxes;
      continue;
    }
    ASSERT_EQ(l->visuals.size(), shown.size()) << link.name << ": drawn with its visual, else its collision geometry";
    for (std::size_t k = 0; k < shown.size(); ++k) {
      EXPECT_EQ(l->visuals[k].type, shown[k].type) << link.name;
      EXPECT_LT((l->visuals[k].X_LG.p - shown[k].X_LG.p).norm(), 1e-15) << link.name;
      if (shown[k].type == model::Geometry::Type::kMesh) {
        ++meshes;
        const auto url = l->visuals[k].mesh_uri;
        const auto it = std::find(d.mesh_urls.begin(), d.mesh_urls.end(), url);
        ASSERT_NE(it, d.mesh_urls.end()) << url;
        EXPECT_EQ(d.mesh_files[static_cast<std::size_t>(it - d.mesh_urls.begin())], shown[k].mesh) << link.name;
      } else {
        EXPECT_LT((l->visuals[k].size - shown[k].size).norm(), 1e-15) << link.name;
      }
    }
  }
  EXPECT_EQ(d.info["base_link"], spec.model.body_name.front());
  EXPECT_EQ(d.info["joints"].size(), static_cast<std::size_t>(spec.model.nj));
  EXPECT_EQ(d.info["held"].size(), spec.model.held_joint_name.size());
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(d.info["feet"][k]["link"], spec.feet[k].link);
    EXPECT_EQ(d.info["feet"][k]["length"].get<double>(), spec.feet[k].length);
  }
  EXPECT_EQ(d.info["inertia_boxes"].get<std::size_t>(), inertia_boxes);
  if (robot == "h1_2") {
    EXPECT_GT(inertia_boxes, 20U) << "the H1-2 file has geometry for its feet only";
  }
  if (robot == "g1") {
    EXPECT_GT(meshes, 30U) << "the G1 is drawn with its meshes";
  }
}

TEST(DisplayRobot, DisplayUrdfHasTheLoadedTree) {
  for (const char* robot : {"toro", "h1_2", "g1"}) {
    SCOPED_TRACE(robot);
    expect_same_tree(robot);
  }
}

template <class Msg>
viewer::LogEvent event(const char* channel, const Msg& m, std::int64_t wall_us) {
  return {wall_us, channel, test::encode(m)};
}

humanoid::robot_state_t state_at(int k) {
  humanoid::robot_state_t m{};
  m.tick = k;
  m.utime = 1'000'000 + 1000LL * k;
  m.quat_WB[0] = 1.0;
  m.num_joints = 1;
  m.joint_name = {"j"};
  m.q = {1e-3 * k};
  m.qd = m.tau = {0.0};
  return m;
}

TEST(Timeline, FramesHoldTheLatestMessageOfEveryChannelOnTheRobotClock) {
  std::vector<viewer::LogEvent> events;
  humanoid::health_t h{};
  h.node = "wbc";
  h.utime = 1'700'000'000'000'000;  // wall clock: must not be taken for the robot's
  events.push_back(event("HEALTH", h, 5));
  events.push_back({6, "SOMETHING_ELSE", {1, 2, 3}});
  for (int k = 0; k < 1000; ++k) {
    events.push_back(event("ROBOT_STATE", state_at(k), 10 + k));
    humanoid::sim_truth_t t{};
    t.tick = k;
    t.utime = 1'000'000 + 1000LL * k;
    t.quat_WB[0] = 1.0;
    t.push_active = k >= 300 && k < 500;
    t.push_force_W[0] = t.push_active ? 50.0 + (k == 400 ? 25.0 : 0.0) : 0.0;
    events.push_back(event("SIM_TRUTH", t, 10 + k));
    if (k == 700) events.push_back({10 + k, "BALANCE_STATUS", {0xde, 0xad}});
  }
  const viewer::Timeline tl(std::move(events), 100.0);
  EXPECT_DOUBLE_EQ(tl.t0(), 1.0);
  EXPECT_NEAR(tl.duration(), 0.999, 1e-12);
  EXPECT_EQ(tl.num_frames(), 100);
  EXPECT_EQ(tl.skipped(), 1U);
  ASSERT_EQ(tl.skip_reasons().size(), 1U);
  EXPECT_NE(tl.skip_reasons()[0].find("BALANCE_STATUS"), std::string::npos);
  for (int i : {0, 1, 37, 99}) {
    const json f = tl.frame(i);
    EXPECT_EQ(f["channels"]["ROBOT_STATE"]["tick"].get<int>(), 10 * i) << "frame " << i;
    EXPECT_EQ(f["channels"]["ROBOT_STATE"]["q"][0].get<double>(), 1e-3 * (10 * i)) << "frame " << i;
    EXPECT_EQ(f["channels"]["SIM_TRUTH"]["tick"].get<int>(), 10 * i) << "frame " << i;
    EXPECT_EQ(f["channels"]["HEALTH"]["node"], "wbc") << "placed at the first clock time, not at its wall-clock utime";
    EXPECT_FALSE(f["channels"].contains("BALANCE_STATUS")) << "only a malformed one was logged";
  }
  const json s = tl.summary();
  ASSERT_EQ(s["pushes"].size(), 1U);
  EXPECT_DOUBLE_EQ(s["pushes"][0]["start"].get<double>(), 1.3);
  EXPECT_DOUBLE_EQ(s["pushes"][0]["end"].get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(s["pushes"][0]["peak_N"].get<double>(), 75.0);
  EXPECT_EQ(s["series"]["t"].size(), 100U);
}

TEST(Timeline, ALogWithoutTheRobotsStateIsRefused) {
  humanoid::health_t h{};
  std::vector<viewer::LogEvent> events{event("HEALTH", h, 1)};
  EXPECT_THROW(viewer::Timeline(std::move(events), 30.0), std::invalid_argument);
}

}  // namespace
