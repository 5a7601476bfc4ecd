// URDF loading: both robots load; malformed or inconsistent descriptions are rejected with a
// message that names the link or joint.
#include <gtest/gtest.h>

#include "hpr/model/model.hpp"
#include "model_fixture.hpp"

namespace {

using hpr::model::Model;
using hpr::model::ModelError;
using hpr::model::parse_urdf;

std::string link(const std::string& name, const std::string& inertial) {
  return "<link name=\"" + name + "\">" + inertial + "</link>\n";
}
std::string inertial(double m, double ixx = 0.01, double iyy = 0.01, double izz = 0.01, double ixy = 0) {
  return "<inertial><mass value=\"" + std::to_string(m) + "\"/><inertia ixx=\"" + std::to_string(ixx) +
         "\" ixy=\"" + std::to_string(ixy) + "\" ixz=\"0\" iyy=\"" + std::to_string(iyy) + "\" iyz=\"0\" izz=\"" +
         std::to_string(izz) + "\"/></inertial>";
}
std::string joint(const std::string& name, const std::string& type, const std::string& parent,
                  const std::string& child) {
  return "<joint name=\"" + name + "\" type=\"" + type + "\"><parent link=\"" + parent + "\"/><child link=\"" +
         child + "\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"10\" velocity=\"1\"/></joint>\n";
}
std::string robot(const std::string& body) { return "<robot name=\"t\">\n" + body + "</robot>"; }

// The message of the ModelError thrown while building a model from `xml`.
std::string error_of(const std::string& xml) {
  try {
    (void)Model::build(parse_urdf(xml, "test.urdf"));
  } catch (const ModelError& e) {
    return e.what();
  }
  return "";
}

TEST(Urdf, BothRobotsLoad) {
  const auto toro = hpr::test::load_robot("toro");
  EXPECT_EQ(toro.model.nj, 27);
  EXPECT_EQ(toro.model.nv, 33);
  EXPECT_NEAR(toro.model.mass, 79.2, 1e-9);
  EXPECT_EQ(toro.free_joints.size(), 15U);
  const auto h1 = hpr::test::load_robot("h1_2");
  EXPECT_EQ(h1.model.nj, 27);
  EXPECT_NEAR(h1.model.mass, 66.98, 0.05);
}

TEST(Urdf, ToroHeightAndSoles) {
  const auto toro = hpr::test::load_robot("toro");
  hpr::model::Data data(toro.model);
  Eigen::VectorXd q = toro.model.neutral();
  hpr::model::forward_kinematics(toro.model, data, q);
  hpr::model::update_frame_placements(toro.model, data);
  const double sole_z = data.oMf[static_cast<size_t>(toro.feet[0].sole_frame)].p.z();
  const int head = toro.model.frame_index("head");
  // Head sphere: centre 0.08 above the neck pitch axis, radius 0.10.
  const double top = data.oMf[static_cast<size_t>(head)].p.z() + 0.08 + 0.10;
  EXPECT_NEAR(top - sole_z, 1.74, 0.01);
}

// Text that is not UTF-8 (a truncated multi-byte character, a NUL) is refused before any XML
// parser reads it, naming the line and byte (found by fuzzing: TinyXML read past such text's end).
TEST(Urdf, TextThatIsNotUtf8IsRejectedNamingLineAndByte) {
  const std::string good = robot(link("base", inertial(1)));
  EXPECT_EQ(error_of(good), "");
  EXPECT_EQ(error_of(robot("<!-- caf\xc3\xa9 \xe2\x82\xac -->\n" + link("base", inertial(1)))), "") << "valid UTF-8 is fine";
  const std::string truncated = robot("\n<link name=\"b\xf3\xf3\">");
  std::string msg = error_of(truncated);
  EXPECT_NE(msg.find("test.urdf:3: byte 31"), std::string::npos) << msg;
  EXPECT_NE(msg.find("(0xf3) is not UTF-8"), std::string::npos) << msg;
  msg = error_of(robot(std::string("<link name=\"a\0b\"/>", 17)));
  EXPECT_NE(msg.find("(0x00) is not UTF-8"), std::string::npos) << msg;
}

TEST(Urdf, MovingLinkWithoutInertiaIsRejected) {
  const std::string msg = error_of(robot(link("base", inertial(1)) + link("arm", "") + joint("j1", "revolute", "base", "arm")));
  EXPECT_NE(msg.find("link 'arm'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("joint 'j1'"), std::string::npos) << msg;
}

TEST(Urdf, NegativeMassIsRejected) {
  const std::string msg = error_of(robot(link("base", inertial(1)) + link("arm", inertial(-1.0)) +
                                         joint("j1", "revolute", "base", "arm")));
  EXPECT_NE(msg.find("link 'arm'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("positive mass"), std::string::npos) << msg;
}

TEST(Urdf, MassZeroOnAMovingLinkLeavesItWithoutInertia) {
  // <inertial> of mass 0 is no inertia: on a link moved by a joint, with nothing fixed to it, that
  // is the error of a moving link without inertia.
  const std::string msg = error_of(robot(link("base", inertial(1)) + link("arm", inertial(0.0)) +
                                         joint("j1", "revolute", "base", "arm")));
  EXPECT_NE(msg.find("link 'arm'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("no inertia"), std::string::npos) << msg;
}

TEST(Urdf, NonFiniteNumbersAreRejectedNamingTheElement) {
  const std::string base = link("base", inertial(1));
  // NaN mass, NaN in a joint origin, NaN joint limit.
  std::string msg = error_of(robot(base + "<link name=\"arm\"><inertial><mass value=\"nan\"/><inertia ixx=\"1\" "
                                   "ixy=\"0\" ixz=\"0\" iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial></link>" +
                                   joint("j1", "revolute", "base", "arm")));
  EXPECT_NE(msg.find("arm"), std::string::npos) << msg;
  msg = error_of(robot(base + link("arm", inertial(1)) +
                       "<joint name=\"j1\" type=\"revolute\"><parent link=\"base\"/><child link=\"arm\"/>"
                       "<origin xyz=\"0 nan 0\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" "
                       "velocity=\"1\"/></joint>"));
  EXPECT_NE(msg.find("j1"), std::string::npos) << msg;
  msg = error_of(robot(base + link("arm", inertial(1)) +
                       "<joint name=\"j1\" type=\"revolute\"><parent link=\"base\"/><child link=\"arm\"/>"
                       "<axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"nan\" velocity=\"1\"/></joint>"));
  EXPECT_NE(msg.find("j1"), std::string::npos) << msg;
}

TEST(Urdf, MissingParentLinkIsNamed) {
  const std::string msg = error_of(robot(link("base", inertial(1)) + link("arm", inertial(1)) +
                                         joint("j1", "revolute", "nowhere", "arm")));
  EXPECT_NE(msg.find("joint 'j1'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'nowhere'"), std::string::npos) << msg;
}

TEST(Urdf, InertiaNotPositiveDefiniteIsRejected) {
  const std::string msg = error_of(robot(link("base", inertial(1)) + link("arm", inertial(1, 0.01, -0.02, 0.01)) +
                                         joint("j1", "revolute", "base", "arm")));
  EXPECT_NE(msg.find("link 'arm'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not positive definite"), std::string::npos) << msg;
}

TEST(Urdf, TriangleInequalityViolationIsRejected) {
  const std::string msg = error_of(robot(link("base", inertial(1)) + link("arm", inertial(1, 0.01, 0.01, 0.05)) +
                                         joint("j1", "revolute", "base", "arm")));
  EXPECT_NE(msg.find("link 'arm'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("triangle inequality"), std::string::npos) << msg;
}

TEST(Urdf, SecondFloatingJointIsRejected) {
  const std::string msg = error_of(robot(link("world", "") + link("base", inertial(1)) + link("arm", inertial(1)) +
                                         joint("float1", "floating", "world", "base") +
                                         joint("float2", "floating", "base", "arm")));
  EXPECT_NE(msg.find("joint 'float2'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("second floating joint"), std::string::npos) << msg;
}

TEST(Urdf, LoopIsRejected) {
  // a -> b -> c, and c -> b closes a loop: b has two parents.
  const std::string msg = error_of(robot(link("a", inertial(1)) + link("b", inertial(1)) + link("c", inertial(1)) +
                                         joint("j1", "revolute", "a", "b") + joint("j2", "revolute", "b", "c") +
                                         joint("j3", "revolute", "c", "b")));
  EXPECT_NE(msg.find("link 'b'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'j3'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("loop"), std::string::npos) << msg;
  // A cycle with no root at all.
  const std::string msg2 = error_of(robot(link("a", inertial(1)) + link("b", inertial(1)) +
                                          joint("j1", "revolute", "a", "b") + joint("j2", "revolute", "b", "a")));
  EXPECT_NE(msg2.find("loop"), std::string::npos) << msg2;
}

TEST(Urdf, MalformedXmlNamesTheLine) {
  const std::string msg = error_of("<robot name=\"t\">\n<link name=\"a\">\n</robot>");
  EXPECT_NE(msg.find("test.urdf"), std::string::npos) << msg;
  EXPECT_NE(msg.find("XML"), std::string::npos) << msg;
}

TEST(Urdf, FixedJointsMergeIntoTheParentBody) {
  // base + fixed child of 1 kg at x = 1: one body of 2 kg with the CoM at x = 0.5.
  const std::string xml = robot(link("base", inertial(1)) + link("tip", "<inertial><origin xyz=\"0 0 0\"/>" +
                                inertial(1).substr(10)) +
                                "<joint name=\"f\" type=\"fixed\"><parent link=\"base\"/><child link=\"tip\"/>"
                                "<origin xyz=\"1 0 0\"/></joint>");
  const Model m = Model::build(parse_urdf(xml, "t.urdf"));
  EXPECT_EQ(m.nb, 1);
  EXPECT_NEAR(m.inertia[0].m, 2.0, 1e-12);
  EXPECT_NEAR(m.inertia[0].com().x(), 0.5, 1e-12);
  EXPECT_TRUE(m.has_frame("tip"));
}

}  // namespace
