// PUSH messages: what the documented ranges accept, and every value outside them refused with the
// field and value named (never turned into some other push).
#include <gtest/gtest.h>

#include "hpr/sim/sim_io.hpp"
#include "model_fixture.hpp"

namespace {

using namespace hpr;

humanoid::push_t push(double fx, double duration) {
  humanoid::push_t p{};
  p.id = 7;
  p.link = "pelvis";
  p.force_W[0] = fx;
  p.start_time = -1.0;
  p.duration = duration;
  p.profile = humanoid::push_t::PROFILE_HALF_SINE;
  return p;
}

TEST(PushMessage, InRangeIsAcceptedAsSent) {
  const auto robot = test::load_robot("toro");
  std::string why;
  auto p = push(65.0, 0.2);
  p.profile = humanoid::push_t::PROFILE_RECTANGLE;
  const auto out = sim::from_message(p, robot.model, &why);
  ASSERT_TRUE(out.has_value()) << why;
  EXPECT_EQ(out->id, 7);
  EXPECT_EQ(out->force_W.x(), 65.0);
  EXPECT_EQ(out->profile, sim::Push::Profile::kRectangle);
}

TEST(PushMessage, OutOfRangeValuesAreRefusedNamingThem) {
  const auto robot = test::load_robot("toro");
  struct Case {
    humanoid::push_t p;
    const char* expect;
  };
  std::vector<Case> cases;
  cases.push_back({push(1e9, 0.2), "force (1000000000"});
  cases.push_back({push(std::nan(""), 0.2), "force (nan"});
  cases.push_back({push(65.0, 1e9), "duration 1000000000 s"});
  cases.push_back({push(65.0, 0.0), "duration 0 s"});
  auto far = push(65.0, 0.2);
  far.point_L[2] = 100.0;
  cases.push_back({far, "point (0, 0, 100)"});
  auto late = push(65.0, 0.2);
  late.start_time = 1e9;
  cases.push_back({late, "start time 1000000000 s"});
  auto profile = push(65.0, 0.2);
  profile.profile = 7;
  cases.push_back({profile, "profile 7"});
  auto link = push(65.0, 0.2);
  link.link = "no_such_link";
  cases.push_back({link, "link 'no_such_link'"});
  for (const auto& c : cases) {
    std::string why;
    EXPECT_FALSE(sim::from_message(c.p, robot.model, &why).has_value()) << c.expect;
    EXPECT_NE(why.find(c.expect), std::string::npos) << why;
  }
}

}  // namespace
