// The components of the control graph allocate nothing once running: over a push (the CAM strategy
// with the estimator in the loop, every phase of the reference generator, working-set changes of
// both QPs), each component's step is counted apart from the simulator and the message
// conversions around it.
#include <gtest/gtest.h>

#include <array>

#include "allocation_counter.hpp"
#include "closed_loop.hpp"

namespace {

using hpr::test::ClosedLoop;
using hpr::pipeline::Component;

TEST(Components, NoneAllocatesDuringAPush) {
  ClosedLoop loop("toro", {}, {.cam = true, .estimator_in_loop = true});
  loop.push_base(20.0, 65.0, Eigen::Vector3d::UnitX(), 2.0);
  loop.run(1.5);  // standing: every buffer has had its size
  std::array<long, 4> allocations{}, steps{};
  long before = 0;
  loop.probe = [&](Component c, bool entering) {
    if (entering) {
      before = hpr::test::allocations();
      return;
    }
    allocations[static_cast<size_t>(c)] += hpr::test::allocations() - before;
    ++steps[static_cast<size_t>(c)];
  };
  bool generated = false;
  loop.run(3.0, [&] { generated = generated || loop.cam.generating(); });
  ASSERT_FALSE(loop.sim.truth().fallen);
  ASSERT_TRUE(generated) << "the push should start the CAM generation";
  const std::array<const char*, 4> names{"estimator", "reference_gen", "motion_opt", "wbc"};
  for (size_t c = 0; c < 4; ++c) {
    EXPECT_EQ(steps[c], 3000) << names[c];
    EXPECT_EQ(allocations[c], 0) << names[c] << " allocated in " << steps[c] << " steps";
  }
}

}  // namespace
