// The components of the control graph allocate nothing once running: over a push (the CAM strategy
// with the estimator in the loop, every phase of the reference generator, working-set changes of
// both QPs), each component's step is counted apart from the simulator and the message
// conversions around it. They share one interface (hpr/common/component.hpp), and composed they
// report under their own keys.
#include <gtest/gtest.h>

#include <LinearMath/btAlignedAllocator.h>

#include <array>
#include <atomic>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "allocation_counter.hpp"
#include "closed_loop.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/graph/data_flow.hpp"

namespace {

using hpr::test::ClosedLoop;
using hpr::graph::Component;

TEST(Components, NoneAllocatesDuringAPush) {
  ClosedLoop loop("toro", {}, {.cam = true, .estimator_in_loop = true});
  loop.push_base(20.0, 65.0, Eigen::Vector3d::UnitX(), 2.0);
  loop.run(1.5);  // standing: every buffer has had its size
  std::array<long, 5> allocations{}, steps{};
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
  loop.run(3.0, [&] { generated = generated || loop.cam().generating(); });
  ASSERT_FALSE(loop.sim.truth().fallen);
  ASSERT_TRUE(generated) << "the push should start the CAM generation";
  const std::array<const char*, 5> names{"estimator", "planner", "reference_gen", "motion_opt", "wbc"};
  static_assert(static_cast<size_t>(Component::kWbc) + 1 == names.size());
  for (size_t c = 0; c < names.size(); ++c) {
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
    loop.sim.step({&loop.wbc_out().command}, out);
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

static_assert(hpr::Component<hpr::estimator::Estimator>);
static_assert(hpr::Component<hpr::reference_gen::ReferenceGenerator>);
static_assert(hpr::Component<hpr::motion_opt::MotionOptComponent>);
static_assert(hpr::Component<hpr::wbc::WbcComponent>);

// Composed, the five report in one process's HEALTH: their fault keys must not collide, and the
// composed controllers hand on each one's report as it made it. A sensor dropout (the estimate
// republished flagged stale) ends, after wbc.bad_state_ticks ticks, in the wbc's damping fault with
// the text the wbc process reports.
TEST(Components, ComposedTheyReportUnderTheirOwnKeysAndADropoutEndsInTheWbcsDamping) {
  std::set<std::string> keys;
  std::size_t declared = 0;
  auto add = [&](const auto& k) {
    declared += k.size();
    keys.insert(k.begin(), k.end());
  };
  add(hpr::estimator::Estimator::kFaultKeys);
  add(hpr::planner::BalancePlanner::kFaultKeys);
  add(hpr::reference_gen::ReferenceGenerator::kFaultKeys);
  add(hpr::motion_opt::MotionOptComponent::kFaultKeys);
  add(hpr::wbc::WbcComponent::kFaultKeys);
  EXPECT_EQ(keys.size(), declared) << "two components declare the same fault key";

  ClosedLoop loop("toro", {}, {.cam = true, .estimator_in_loop = true});
  loop.run(0.5);
  ASSERT_EQ(loop.reports().size(), 5u);  // estimator, planner, reference_gen, motion_opt, wbc
  for (const hpr::StepReport* r : loop.reports()) {
    EXPECT_EQ(r->outcome, hpr::StepOutcome::kRunning);
    for (const auto& f : r->faults()) EXPECT_NE(f.change, hpr::StepReport::Change::kRaised) << f.key << ": " << f.message();
  }
  const hpr::StepReport& wbc = *loop.reports().back();
  EXPECT_EQ(&wbc, &loop.wbc_out().report);
  const int bad_state_ticks = 20;  // config/toro.yaml
  for (int k = 1; k <= bad_state_ticks; ++k) {
    loop.control(hpr::EstimatedState::kSensorStale);
    const bool damps = k == bad_state_ticks;
    EXPECT_EQ(wbc.raised("damping"), damps) << "stale tick " << k;
    EXPECT_EQ(wbc.outcome, damps ? hpr::StepOutcome::kDamping : hpr::StepOutcome::kRunning) << "stale tick " << k;
  }
  EXPECT_EQ(wbc.fault("damping").message(), "ROBOT_STATE flagged (status 1) for 20 ticks");
  EXPECT_EQ(loop.wbc_out().mode, hpr::wbc::WbcComponent::Mode::kDampBadState);
}

/// The cells of a Markdown table row ("| a | b |" → {"a", "b"}).
std::vector<std::string> cells(const std::string& row) {
  std::vector<std::string> out;
  std::stringstream ss(row.substr(1));
  std::string c;
  while (std::getline(ss, c, '|')) {
    const auto b = c.find_first_not_of(' '), e = c.find_last_not_of(' ');
    out.push_back(b == std::string::npos ? std::string() : c.substr(b, e - b + 1));
  }
  return out;
}

/// "BALANCE_STATUS k−1 (posture error), CAM_REFERENCE k" → {{"BALANCE_STATUS", -1}, {"CAM_REFERENCE", 0}}.
std::map<std::string, int> ticked_channels(const std::string& cell) {
  std::map<std::string, int> out;
  std::stringstream ss(cell);
  std::string item;
  while (std::getline(ss, item, ',')) {
    std::stringstream words(item);
    std::string channel, tick;
    words >> channel >> tick;
    if (channel.empty()) continue;
    out[channel] = tick == "k" ? 0 : tick == "k\u22121" ? -1 : 99;
  }
  return out;
}

/// "`damping`, `contact_qp`" → {"damping", "contact_qp"}.
std::set<std::string> quoted(const std::string& cell) {
  std::set<std::string> out;
  for (std::size_t b = cell.find('`'); b != std::string::npos; b = cell.find('`', cell.find('`', b + 1) + 1)) {
    out.insert(cell.substr(b + 1, cell.find('`', b + 1) - b - 1));
  }
  return out;
}

// The README's table of the components (what each steps on, reads at which tick, writes, and the
// HEALTH faults it reports) says what the declarations say: the declared ports (hpr/graph/data_flow.hpp) and
// each component's kFaultKeys. OPERATOR, a command rather than a data channel, is left out of it.
TEST(Components, TheReadmesTableSaysWhatTheDeclarationsSay) {
  std::ifstream readme(hpr::test::source_dir() + "/README.md");
  ASSERT_TRUE(readme) << "README.md";
  const std::map<std::string, std::pair<std::string, std::set<std::string>>> components{
      {"`estimator::Estimator`", {"estimator", {hpr::estimator::Estimator::kFaultKeys.begin(), hpr::estimator::Estimator::kFaultKeys.end()}}},
      {"`planner::BalancePlanner`", {"planner", {hpr::planner::BalancePlanner::kFaultKeys.begin(), hpr::planner::BalancePlanner::kFaultKeys.end()}}},
      {"`reference_gen::ReferenceGenerator`",
       {"reference_gen",
        {hpr::reference_gen::ReferenceGenerator::kFaultKeys.begin(), hpr::reference_gen::ReferenceGenerator::kFaultKeys.end()}}},
      {"`motion_opt::MotionOptComponent`",
       {"motion_opt", {hpr::motion_opt::MotionOptComponent::kFaultKeys.begin(), hpr::motion_opt::MotionOptComponent::kFaultKeys.end()}}},
      {"`wbc::WbcComponent`", {"wbc", {hpr::wbc::WbcComponent::kFaultKeys.begin(), hpr::wbc::WbcComponent::kFaultKeys.end()}}},
  };
  std::set<std::string> seen, first_cells;
  std::string line;
  while (std::getline(readme, line)) {
    if (line.rfind("| `", 0) != 0) continue;
    const auto row = cells(line);
    first_cells.insert(row[0]);
    const auto it = components.find(row[0]);
    if (it == components.end() || row.size() < 5) continue;
    const auto& [process, fault_keys] = it->second;
    seen.insert(process);
    const hpr::Ports* p = hpr::graph::find_process(process);
    ASSERT_NE(p, nullptr) << process;
    std::map<std::string, int> steps_on, reads, writes;
    for (const auto& r : p->reads) {
      if (r.channel == hpr::msg::channels::kOperator.name) continue;
      (r.trigger ? steps_on : reads)[std::string(r.channel)] = r.tick_offset;
    }
    for (const auto& w : p->writes) writes[std::string(w)] = 0;
    EXPECT_EQ(ticked_channels(row[1]), steps_on) << process << ": steps on";
    EXPECT_EQ(ticked_channels(row[2]), reads) << process << ": reads";
    EXPECT_EQ(ticked_channels(row[3]), writes) << process << ": writes";
    EXPECT_EQ(quoted(row[4]), fault_keys) << process << ": HEALTH faults";
  }
  EXPECT_EQ(seen.size(), components.size()) << "a component is missing from the README's table";
  // And its table of the processes has every process of the data flow.
  for (const auto& p : hpr::graph::data_flow()) EXPECT_TRUE(first_cells.count("`" + std::string(p.name) + "`")) << p.name;
}

}  // namespace
