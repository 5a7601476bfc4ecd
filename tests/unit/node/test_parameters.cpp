// Live parameters: an OPERATOR set is applied all or nothing, only the keys of its own node, inside
// the registered ranges; a setter's refusal undoes what the set had already changed.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "hpr/common/parameters.hpp"

namespace {

using hpr::Parameter;
using hpr::ParameterSet;

struct Gains {
  double kp = 100.0, kd = 10.0;
  double on = 30.0, off = 5.0;
  int recomputed = 0;
};

ParameterSet make(Gains& g) {
  ParameterSet p("wbc");
  p.add("com.stiffness.z", g.kp, 0.0, 1e6, "N/m", [&g] { ++g.recomputed; });
  p.add("com.damping.z", g.kd, 0.0, 1e5, "N s/m");
  // A pair with a cross constraint, as the estimator's contact hysteresis.
  p.add(Parameter{"contact_on", "N", 0.0, 1e4, [&g] { return g.on; }, [&g](double v) {
                    if (v < g.off) return std::string("below contact_off");
                    g.on = v;
                    return std::string();
                  }});
  p.add(Parameter{"contact_off", "N", 0.0, 1e4, [&g] { return g.off; }, [&g](double v) {
                    if (v > g.on) return std::string("above contact_on");
                    g.off = v;
                    return std::string();
                  }});
  return p;
}

TEST(Parameters, AppliesTheKeysOfItsNodeOnly) {
  Gains g;
  ParameterSet p = make(g);
  const auto r = p.apply({"wbc.com.stiffness.z", "reference_gen.alpha", "wbc.com.damping.z"}, {2500.0, 0.7, 55.0});
  EXPECT_TRUE(r.addressed);
  EXPECT_TRUE(r.applied) << r.text;
  EXPECT_EQ(r.changed, 2);
  EXPECT_EQ(g.kp, 2500.0);
  EXPECT_EQ(g.kd, 55.0);
  EXPECT_EQ(g.recomputed, 1);
  EXPECT_EQ(p.version(), 1);
  EXPECT_NE(r.text.find("com.stiffness.z 100 -> 2500 N/m"), std::string::npos) << r.text;
  EXPECT_EQ(r.text.find("alpha"), std::string::npos) << r.text;
}

TEST(Parameters, IgnoresASetForOtherNodes) {
  Gains g;
  ParameterSet p = make(g);
  // "wbcx." is not "wbc.": a prefix must end at the dot.
  const auto r = p.apply({"reference_gen.alpha", "wbcx.com.stiffness.z"}, {0.7, 1.0});
  EXPECT_FALSE(r.addressed);
  EXPECT_FALSE(r.applied);
  EXPECT_EQ(g.kp, 100.0);
  EXPECT_EQ(p.version(), 0);
}

TEST(Parameters, RefusesTheWholeSetForOneBadPair) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* key;
    double value;
    const char* says;
  };
  for (const Case& c : {Case{"wbc.com.stifness.z", 1.0, "no such live parameter"}, Case{"wbc.com.damping.z", nan, "not a finite number"},
                        Case{"wbc.com.damping.z", inf, "not a finite number"}, Case{"wbc.com.damping.z", -1.0, "outside [0, 100000] N s/m"},
                        Case{"wbc.com.damping.z", 2e5, "outside [0, 100000]"}}) {
    Gains g;
    ParameterSet p = make(g);
    // The good pair comes first: it must not be applied either.
    const auto r = p.apply({"wbc.com.stiffness.z", c.key}, {2500.0, c.value});
    EXPECT_TRUE(r.addressed);
    EXPECT_FALSE(r.applied) << c.key;
    EXPECT_EQ(g.kp, 100.0) << c.key;
    EXPECT_EQ(g.kd, 10.0) << c.key;
    EXPECT_EQ(g.recomputed, 0) << c.key;
    EXPECT_EQ(p.version(), 0);
    EXPECT_NE(r.text.find(c.says), std::string::npos) << r.text;
    EXPECT_NE(r.text.find(c.key), std::string::npos) << r.text;
  }
}

TEST(Parameters, ASetterRefusalUndoesTheSetNewestFirst) {
  Gains g;
  ParameterSet p = make(g);
  // contact_on 50 is applied, then contact_off 60 exceeds it: both must be as before, and the
  // stiffness applied first as well.
  const auto r = p.apply({"wbc.com.stiffness.z", "wbc.contact_on", "wbc.contact_off"}, {2500.0, 50.0, 60.0});
  EXPECT_FALSE(r.applied);
  EXPECT_NE(r.text.find("contact_off = 60: above contact_on"), std::string::npos) << r.text;
  EXPECT_EQ(g.kp, 100.0);
  EXPECT_EQ(g.on, 30.0);
  EXPECT_EQ(g.off, 5.0);
  // In an order that keeps on above off, the same pair is accepted.
  const auto ok = p.apply({"wbc.contact_on", "wbc.contact_off"}, {70.0, 60.0});
  EXPECT_TRUE(ok.applied) << ok.text;
  EXPECT_EQ(g.on, 70.0);
  EXPECT_EQ(g.off, 60.0);
}

TEST(Parameters, AKeyForSeveralValuesIsUndoneThroughThem) {
  // "gain" sets three axes and reads NaN while they differ, like reference_gen's "alpha".
  std::array<double, 3> axes{0.7, 0.8, 0.9};
  bool refuse = true;
  ParameterSet p("reference_gen");
  p.add(Parameter{"gain", "", 0.0, 1.0,
                  [&] { return axes[0] == axes[1] && axes[1] == axes[2] ? axes[0] : std::nan(""); },
                  [&](double v) {
                    axes.fill(v);
                    return std::string();
                  }});
  for (std::size_t i = 0; i < 3; ++i) p.add("gain." + std::to_string(i), axes[i], 0.0, 1.0, "");
  p.add(Parameter{"picky", "", 0.0, 1.0, [] { return 0.5; }, [&](double) { return refuse ? std::string("refused") : std::string(); }});
  const auto r = p.apply({"reference_gen.gain", "reference_gen.picky"}, {0.5, 0.1});
  EXPECT_FALSE(r.applied);
  EXPECT_EQ(axes[0], 0.7);
  EXPECT_EQ(axes[1], 0.8);
  EXPECT_EQ(axes[2], 0.9);
  refuse = false;
  EXPECT_TRUE(p.apply({"reference_gen.gain", "reference_gen.picky"}, {0.5, 0.1}).applied);
  EXPECT_EQ(axes[1], 0.5);
}

TEST(Parameters, RegistrationErrorsAreProgrammingErrors) {
  Gains g;
  ParameterSet p = make(g);
  double x = 0;
  EXPECT_THROW(p.add("com.stiffness.z", x, 0, 1, ""), std::logic_error);
  EXPECT_THROW(p.add("new", x, 1, 0, ""), std::logic_error);
  EXPECT_THROW(p.add(Parameter{"no_setter", "", 0, 1, [] { return 0.0; }, {}}), std::logic_error);
  ASSERT_NE(p.find("contact_off"), nullptr);
  EXPECT_EQ(p.find("contact"), nullptr);
}

}  // namespace
