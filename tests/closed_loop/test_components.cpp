// The components of the control graph allocate nothing once running: over a push (the CAM strategy
// with the estimator in the loop, every phase of the reference generator, working-set changes of
// both QPs), each component's step is counted apart from the simulator and the message
// conversions around it.
#include <gtest/gtest.h>

#include <LinearMath/btAlignedAllocator.h>

#include <array>
#include <atomic>
#include <cstdlib>

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

std::atomic<long> g_bullet_allocations{0};
void* counting_bullet_alloc(size_t n) {
  ++g_bullet_allocations;
  return std::malloc(n);
}
void plain_free(void* p) { std::free(p); }

// The simulator's step, as a component of the graph (JOINT_COMMAND in, ROBOT_SENSORS and
// SIM_TRUTH out): what it allocates per tick over the same push, C++ allocations and Bullet's own
// (btAlignedAlloc, which goes to malloc) counted.
TEST(Components, TheSimulatorsStepAllocatesNothingDuringAPush) {
  // Bullet's allocator through a counter (malloc and free underneath, as Bullet's default: memory
  // allocated before this frees the same way).
  btAlignedAllocSetCustom(counting_bullet_alloc, plain_free);
  ClosedLoop loop("toro", {}, {.cam = true, .estimator_in_loop = true});
  ASSERT_GT(g_bullet_allocations.load(), 0) << "Bullet's allocations are not seen by the counter";
  loop.push_base(20.0, 65.0, Eigen::Vector3d::UnitX(), 2.0);
  loop.run(1.5);
  long allocations = 0, bullet = 0;
  hpr::sim::Simulator::Outputs out;
  for (int i = 0; i < 3000; ++i) {
    loop.control();
    const long before = hpr::test::allocations(), bullet_before = g_bullet_allocations.load();
    loop.sim.step({&loop.wbc_out.command}, out);
    allocations += hpr::test::allocations() - before;
    bullet += g_bullet_allocations.load() - bullet_before;
    loop.estimate(loop.sensors_as_received());
    ASSERT_TRUE(out.command_taken);
  }
  ASSERT_FALSE(loop.sim.truth().fallen);
  EXPECT_EQ(out.sensors, &loop.sim.sensors());
  EXPECT_EQ(allocations, 0) << "the simulator allocated in 3000 steps";
  EXPECT_EQ(bullet, 0) << "Bullet allocated in 3000 steps";
  btAlignedAllocSetCustom(nullptr, nullptr);
}

}  // namespace
