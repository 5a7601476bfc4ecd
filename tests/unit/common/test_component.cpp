// The report a component's tick makes (hpr/common/component.hpp): declared keys only, texts cut to
// their fixed storage, each tick starting from "running, nothing changed".
#include <gtest/gtest.h>

#include <array>
#include <string>
#include <string_view>

#include "hpr/common/component.hpp"

namespace {

using hpr::StepReport;

constexpr std::array<std::string_view, 2> kKeys{"qp", "stale"};

TEST(StepReport, RaisesClearsAndLeavesTheDeclaredFaults) {
  StepReport r(kKeys);
  r.begin();
  EXPECT_EQ(r.outcome, hpr::StepOutcome::kRunning);
  r.raise("qp", "QP failed ({}) after {} iterations", "infeasible", 12);
  r.clear("stale");
  r.outcome = hpr::StepOutcome::kDamping;
  EXPECT_TRUE(r.raised("qp"));
  EXPECT_EQ(r.fault("qp").message(), "QP failed (infeasible) after 12 iterations");
  EXPECT_EQ(r.fault("stale").change, StepReport::Change::kCleared);
  r.begin();  // the next tick
  EXPECT_EQ(r.outcome, hpr::StepOutcome::kRunning);
  for (const auto& f : r.faults()) EXPECT_EQ(f.change, StepReport::Change::kUnchanged) << f.key;
  r.set("stale", true, "input stale");
  r.set("qp", false, "unused");
  EXPECT_EQ(r.fault("stale").message(), "input stale");
  EXPECT_EQ(r.fault("qp").change, StepReport::Change::kCleared);
}

TEST(StepReport, AKeyTheComponentDidNotDeclareIsALogicError) {
  StepReport r(kKeys);
  try {
    r.clear("qpp");
    ADD_FAILURE() << "an undeclared key was accepted";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("'qpp'"), std::string::npos) << e.what();
  }
  const std::array<std::string_view, StepReport::kMaxFaults + 1> too_many{};
  EXPECT_THROW(StepReport{too_many}, std::logic_error);
}

TEST(StepReport, ATextLongerThanItsStorageIsCut) {
  StepReport r(kKeys);
  const std::string long_text(StepReport::kTextSize + 50, 'x');
  r.raise("qp", "{}", long_text);
  EXPECT_EQ(r.fault("qp").message(), long_text.substr(0, StepReport::kTextSize));
}

TEST(OptionalRef, IsEmptyOrRefersToTheValue) {
  const int v = 3;
  const hpr::OptionalRef<int> none, some(v), absent = std::nullopt;
  EXPECT_FALSE(none.has_value());
  EXPECT_FALSE(absent);
  EXPECT_THROW((void)none.value(), std::bad_optional_access);
  ASSERT_TRUE(some);
  EXPECT_EQ(&*some, &v);
  EXPECT_FALSE(hpr::OptionalRef<int>::when(false, v));
  EXPECT_EQ(&hpr::OptionalRef<int>::when(true, v).value(), &v);
}

}  // namespace
