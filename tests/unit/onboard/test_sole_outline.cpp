// The sole rectangle of an outline, against rectangles and polygons whose largest inscribed
// rectangle is known in closed form, and the sole of feet whose geometry is yawed in the link.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "hpr/onboard/robot_check.hpp"
#include "hpr/onboard/sole_outline.hpp"
#include "model_fixture.hpp"

namespace {

using namespace hpr;
using Eigen::Vector2d;

std::vector<Vector2d> rectangle(double length, double width, double yaw, Vector2d centre) {
  const Eigen::Rotation2Dd R(yaw);
  std::vector<Vector2d> p;
  for (double sx : {-0.5, 0.5}) {
    for (double sy : {-0.5, 0.5}) p.push_back(centre + R * Vector2d(sx * length, sy * width));
  }
  // Interior points never change the hull.
  p.push_back(centre);
  p.push_back(centre + R * Vector2d(0.1 * length, 0.2 * width));
  return p;
}

TEST(SoleOutline, ConvexHullIsCounterClockwiseWithoutCollinearOrRepeatedPoints) {
  const std::vector<Vector2d> pts = {{0, 0}, {1, 0}, {0.5, 0}, {1, 1}, {0, 1}, {0.5, 0.5}, {1, 1}, {0, 0.5}};
  const auto h = onboard::convex_hull_2d(pts);
  ASSERT_EQ(h.size(), 4U);
  double area = 0;
  for (size_t i = 0; i < h.size(); ++i) {
    const Vector2d& a = h[i];
    const Vector2d& b = h[(i + 1) % h.size()];
    area += 0.5 * (a.x() * b.y() - b.x() * a.y());
  }
  EXPECT_DOUBLE_EQ(area, 1.0) << "positive: counter-clockwise";
  EXPECT_EQ(onboard::convex_hull_2d({{0, 0}, {1, 1}, {2, 2}}).size(), 2U);
}

TEST(SoleOutline, AnAxisAlignedRectangleIsItself) {
  const auto s = onboard::sole_rectangle(rectangle(0.22, 0.1, 0.0, {0.03, -0.01}));
  EXPECT_NEAR(s.length, 0.22, 1e-12);
  EXPECT_NEAR(s.width, 0.1, 1e-12);
  EXPECT_EQ(s.yaw, 0.0);
  EXPECT_LT((s.centre - Vector2d(0.03, -0.01)).norm(), 1e-12);
}

TEST(SoleOutline, AYawedRectangleGivesItsYawAndSizeWhateverTheAngle) {
  for (const double deg : {-80.0, -30.0, 5.0, 30.0, 60.0, 89.0}) {
    const double yaw = deg * M_PI / 180.0;
    const auto s = onboard::sole_rectangle(rectangle(0.2, 0.08, yaw, {0.01, 0.02}));
    EXPECT_NEAR(s.yaw, yaw, 1e-9) << deg;
    EXPECT_NEAR(s.length, 0.2, 1e-9) << deg;
    EXPECT_NEAR(s.width, 0.08, 1e-9) << deg;
    EXPECT_LT((s.centre - Vector2d(0.01, 0.02)).norm(), 1e-9) << deg;
  }
  // The axis is a line: its end nearer the forward direction is +x.
  const auto back = onboard::sole_rectangle(rectangle(0.2, 0.08, M_PI, {0, 0}));
  EXPECT_NEAR(back.yaw, 0.0, 1e-9);
  const auto side = onboard::sole_rectangle(rectangle(0.2, 0.08, 0.0, {0, 0}), M_PI / 2);
  EXPECT_NEAR(std::abs(side.yaw), 0.0, 1e-9) << "the long axis, whatever the forward direction";
}

TEST(SoleOutline, ChamferedCornersAreLeftOutAndATrapezoidKeepsItsNarrowEnd) {
  // 0.20 x 0.08 with 5 mm chamfers: the full length is 0.07 wide (area 0.014), 0.19 is 0.08 wide
  // (0.0152), and the area (0.2 - 2t)(0.07 + 2t) grows up to t = 5 mm.
  const double c = 0.005;
  const std::vector<Vector2d> oct = {{0.1, 0.04 - c}, {0.1 - c, 0.04}, {-0.1 + c, 0.04}, {-0.1, 0.04 - c},
                                     {-0.1, -0.04 + c}, {-0.1 + c, -0.04}, {0.1 - c, -0.04}, {0.1, -0.04 + c}};
  const auto s = onboard::sole_rectangle(oct);
  EXPECT_NEAR(s.length, 0.19, 1e-9);
  EXPECT_NEAR(s.width, 0.08, 1e-9);
  EXPECT_LT(s.centre.norm(), 1e-9);
  EXPECT_EQ(s.yaw, 0.0);
  // Heel 0.05 wide at x = -0.05, toe 0.06 wide at x = 0.12: the area (0.17 - t)(0.05 + t 0.01/0.17)
  // only shrinks with t, so the whole length at the heel's width.
  const auto g1 = onboard::sole_rectangle({{-0.05, -0.025}, {-0.05, 0.025}, {0.12, -0.03}, {0.12, 0.03}});
  EXPECT_NEAR(g1.length, 0.17, 1e-12);
  EXPECT_NEAR(g1.width, 0.05, 1e-12);
  EXPECT_EQ(g1.yaw, 0.0);
  EXPECT_LT((g1.centre - Vector2d(0.035, 0.0)).norm(), 1e-12);
}

TEST(SoleOutline, ASquareTakesTheForwardDirectionAndASegmentHasNoWidth) {
  const auto sq = onboard::sole_rectangle(rectangle(0.1, 0.1, 0.3, {0, 0}), 0.3);
  EXPECT_NEAR(sq.yaw, 0.3, 1e-12);
  EXPECT_NEAR(sq.length, 0.1, 1e-9);
  EXPECT_NEAR(sq.width, 0.1, 1e-9);
  const auto seg = onboard::sole_rectangle({{-0.1, 0.0}, {0.1, 0.0}, {0.0, 0.0}});
  EXPECT_NEAR(seg.length, 0.2, 1e-12);
  EXPECT_EQ(seg.width, 0.0);
}

model::LinkDesc foot_with(model::Geometry g) {
  model::LinkDesc l;
  l.name = "foot";
  l.collisions.push_back(std::move(g));
  return l;
}

TEST(SoleFromGeometry, AFootMeshYawed90DegInTheLinkGivesItsRealSoleCentred) {
  // The mesh is 0.20 m long along its own y, 0.08 m wide, chamfered 5 mm; the URDF turns it 90°
  // about z so that its length lies along the link's x, 3 cm ahead of the ankle and 6 cm below.
  model::Geometry g;
  g.type = model::Geometry::Type::kMesh;
  g.mesh = test::source_dir() + "/tests/unit/onboard/fixtures/biped-description-main/meshes/chamfered_foot.stl";
  g.X_LG.R = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  g.X_LG.p = Eigen::Vector3d(0.03, 0.0, -0.06);
  const auto s = onboard::sole_from_geometry(foot_with(g));
  EXPECT_NEAR(s.length, 0.19, 1e-6);
  EXPECT_NEAR(s.width, 0.08, 1e-6);
  EXPECT_EQ(s.yaw, 0.0);
  EXPECT_LT((s.centre - Eigen::Vector3d(0.03, 0.0, -0.06)).norm(), 1e-6);
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  EXPECT_EQ(s.from, "1 mesh");
}

TEST(SoleFromGeometry, ABoxYawedInTheLinkGivesASoleFrameYawedAsMuch) {
  model::Geometry g;
  g.type = model::Geometry::Type::kBox;
  g.size = Eigen::Vector3d(0.22, 0.09, 0.03);
  g.X_LG.R = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  g.X_LG.p = Eigen::Vector3d(0.02, 0.0, -0.05);
  const auto s = onboard::sole_from_geometry(foot_with(g));
  EXPECT_NEAR(s.yaw, 0.4, 1e-9);
  EXPECT_NEAR(s.length, 0.22, 1e-9);
  EXPECT_NEAR(s.width, 0.09, 1e-9);
  EXPECT_LT((s.centre - Eigen::Vector3d(0.02, 0.0, -0.065)).norm(), 1e-9);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(SoleFromGeometry, DegenerateAndOffCentreSolesAreSaid) {
  model::Geometry ball;
  ball.type = model::Geometry::Type::kSphere;
  ball.size = Eigen::Vector3d(0.03, 0, 0);
  const auto point = onboard::sole_from_geometry(foot_with(ball));
  ASSERT_EQ(point.warnings.size(), 1U);
  EXPECT_NE(point.warnings[0].find("degenerate"), std::string::npos) << point.warnings[0];
  EXPECT_NE(point.warnings[0].find("sole_size"), std::string::npos) << point.warnings[0];
  model::Geometry box;
  box.type = model::Geometry::Type::kBox;
  box.size = Eigen::Vector3d(0.2, 0.08, 0.03);
  box.X_LG.p = Eigen::Vector3d(0.0, 0.042, -0.05);
  const auto aside = onboard::sole_from_geometry(foot_with(box));
  ASSERT_EQ(aside.warnings.size(), 1U);
  EXPECT_NE(aside.warnings[0].find("4.2 cm to the side"), std::string::npos) << aside.warnings[0];
  box.X_LG.p = Eigen::Vector3d(0.0, 0.019, -0.05);
  EXPECT_TRUE(onboard::sole_from_geometry(foot_with(box)).warnings.empty()) << "within a quarter of 0.08";
}

}  // namespace
