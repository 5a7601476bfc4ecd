// ArgReader: the command line of the tools, strict about values.
#include <gtest/gtest.h>

#include <stdexcept>

#include "hpr/common/args.hpp"
#include "hpr/common/text.hpp"

namespace {

using hpr::ArgReader;

std::string error_of(std::vector<std::string> argv, void (*use)(ArgReader&)) {
  ArgReader a(std::move(argv));
  try {
    while (a.next()) use(a);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ArgReader, ReadsOptionsValuesAndPositionals) {
  ArgReader a({"--impulse", "18.5", "log.lcm", "--jobs", "-2", "--set", "a.b=1", "--angles", "0,90,,180", "-", "-h"});
  double impulse = 0;
  int jobs = 0;
  std::vector<std::string> positional, sets, angles;
  bool help = false;
  while (a.next()) {
    if (a.is("--impulse")) impulse = a.number();
    else if (a.is("--jobs")) jobs = a.integer();
    else if (a.is("--set")) sets.push_back(a.value());
    else if (a.is("--angles")) angles = a.list();
    else if (a.is("-h", "--help")) help = true;
    else if (a.positional()) positional.push_back(a.current());
    else a.unknown();
  }
  EXPECT_DOUBLE_EQ(impulse, 18.5);
  EXPECT_EQ(jobs, -2) << "a negative value is a value, not an option";
  EXPECT_EQ(sets, std::vector<std::string>{"a.b=1"});
  EXPECT_EQ(angles, (std::vector<std::string>{"0", "90", "180"}));
  EXPECT_EQ(positional, (std::vector<std::string>{"log.lcm", "-"}));
  EXPECT_TRUE(help);
}

TEST(ArgReader, RefusesMalformedValuesNamingOptionAndValue) {
  const auto number = [](ArgReader& a) { (void)a.number(); };
  const auto integer = [](ArgReader& a) { (void)a.integer(); };
  EXPECT_EQ(error_of({"--impulse", "12abc"}, number), "--impulse: '12abc' is not a finite number");
  EXPECT_EQ(error_of({"--impulse", ""}, number), "--impulse: '' is not a finite number");
  EXPECT_EQ(error_of({"--impulse", "nan"}, number), "--impulse: 'nan' is not a finite number");
  EXPECT_EQ(error_of({"--impulse", "1e999"}, number), "--impulse: '1e999' is not a finite number");
  EXPECT_EQ(error_of({"--impulse"}, number), "--impulse needs a value");
  EXPECT_EQ(error_of({"--jobs", "8.5"}, integer), "--jobs: '8.5' is not an integer");
  EXPECT_EQ(error_of({"--jobs", "99999999999"}, integer), "--jobs: '99999999999' is not an integer");
  EXPECT_EQ(error_of({"--bogus"}, [](ArgReader& a) { a.unknown(); }), "unknown option --bogus");
  EXPECT_EQ(error_of({"extra"}, [](ArgReader& a) { a.unknown(); }), "unexpected argument 'extra'");
}

TEST(ArgReader, AnUnknownOptionNamesTheNearestKnownOne) {
  const auto parse = [](ArgReader& a) {
    if (a.is("--impulse") || a.is("--lcm-url") || a.is("--direction")) return;
    a.unknown();
  };
  EXPECT_EQ(error_of({"--impuls"}, parse), "unknown option --impuls (did you mean '--impulse'?)");
  EXPECT_EQ(error_of({"--lcm_url"}, parse), "unknown option --lcm_url (did you mean '--lcm-url'?)");
  EXPECT_EQ(error_of({"--directon=90"}, parse), "unknown option --directon=90 (did you mean '--direction'?)");
  EXPECT_EQ(error_of({"--verbose"}, parse), "unknown option --verbose");  // nothing near
}

TEST(Text, NearestIsAMisspellingOrNothing) {
  EXPECT_EQ(hpr::edit_distance("stiffness", "stifness"), 1);
  EXPECT_EQ(hpr::edit_distance("lcm_url", "lcm-url"), 0);  // '-' and '_' alike
  EXPECT_EQ(hpr::edit_distance("", "abc"), 3);
  EXPECT_EQ(hpr::nearest("stifness", {"damping", "stiffness", "mass"}), "stiffness");
  EXPECT_EQ(hpr::nearest("friction", {"damping", "stiffness"}), "");
  EXPECT_EQ(hpr::did_you_mean("dampng", {"damping"}), " (did you mean 'damping'?)");
}

TEST(SplitList, DropsEmptyItems) {
  EXPECT_EQ(hpr::split_list(""), std::vector<std::string>{});
  EXPECT_EQ(hpr::split_list(",a,,b,"), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(hpr::split_list("x:y", ':'), (std::vector<std::string>{"x", "y"}));
}

}  // namespace
