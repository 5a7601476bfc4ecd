#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "hpr/common/config.hpp"

namespace {

using hpr::Config;
using hpr::ConfigError;

const char* kYaml = R"(wbc:
  com:
    stiffness: 300
    damping: abc
    gains: [1, 2, 3]
  mode: double
  enabled: true
reference_gen:
  alpha: 1.5
)";

// Returns the ConfigError message thrown by f, or "" when nothing was thrown.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(Config, MissingKeyNamesFileAndFullKey) {
  const Config c = Config::parse(kYaml, "stack.yaml");
  const std::string msg = error_of([&] { (void)c.section("wbc").section("com").real("mass"); });
  EXPECT_NE(msg.find("stack.yaml"), std::string::npos) << msg;
  EXPECT_NE(msg.find("missing key 'wbc.com.mass'"), std::string::npos) << msg;
}

TEST(Config, WrongTypeNamesKeyValueAndLine) {
  const Config c = Config::parse(kYaml, "stack.yaml");
  const std::string msg = error_of([&] { (void)c.section("wbc").section("com").real("damping"); });
  EXPECT_NE(msg.find("stack.yaml:4"), std::string::npos) << msg;
  EXPECT_NE(msg.find("wbc.com.damping = abc"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected a number"), std::string::npos) << msg;
}

// YAML allows a list or a mapping as a key; a configuration key must be a name (found by fuzzing:
// the YAML library's conversion error escaped the loader).
TEST(Config, AKeyThatIsNotANameIsAConfigurationError) {
  const Config c = Config::parse("wbc:\n  ? [a, b]\n  : 1\n", "stack.yaml");
  const std::string msg = error_of([&] { c.section("wbc").reject_unknown({"kp"}); });
  EXPECT_NE(msg.find("stack.yaml:2"), std::string::npos) << msg;
  EXPECT_NE(msg.find("wbc: a key that is not a plain name"), std::string::npos) << msg;
}

TEST(Config, OutOfRangeNamesTheRange) {
  const Config c = Config::parse(kYaml, "stack.yaml");
  const std::string msg = error_of([&] { (void)c.section("reference_gen").real("alpha", 0.0, 1.0); });
  EXPECT_NE(msg.find("stack.yaml:9"), std::string::npos) << msg;
  EXPECT_NE(msg.find("reference_gen.alpha = 1.5"), std::string::npos) << msg;
  EXPECT_NE(msg.find("must be in [0, 1]"), std::string::npos) << msg;
}

TEST(Config, ValidValuesAreRead) {
  const Config c = Config::parse(kYaml, "stack.yaml");
  const Config wbc = c.section("wbc");
  EXPECT_DOUBLE_EQ(wbc.section("com").real("stiffness", 0, 1e6), 300.0);
  EXPECT_EQ(wbc.section("com").reals("gains", 3), (std::vector<double>{1, 2, 3}));
  EXPECT_EQ(wbc.choice("mode", {"double", "left", "right"}), "double");
  EXPECT_TRUE(wbc.boolean("enabled"));
  EXPECT_DOUBLE_EQ(wbc.real_or("absent", 7.0), 7.0);
}

TEST(Config, ListOfWrongLengthAndChoiceAreRejected) {
  const Config c = Config::parse(kYaml, "stack.yaml");
  EXPECT_NE(error_of([&] { (void)c.section("wbc").section("com").reals("gains", 2); }).find("expected 2 numbers, got 3"),
            std::string::npos);
  EXPECT_NE(error_of([&] { (void)c.section("wbc").choice("mode", {"left", "right"}); }).find("must be one of: left, right"),
            std::string::npos);
}

TEST(Config, UnknownKeysAreRejected) {
  const Config c = Config::parse(kYaml, "stack.yaml");
  const std::string msg = error_of([&] { c.section("wbc").reject_unknown({"com", "mode"}); });
  EXPECT_NE(msg.find("wbc.enabled"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown key"), std::string::npos) << msg;
  // A misspelt key names the one meant.
  const std::string typo = error_of([&] { c.section("wbc").reject_unknown({"com", "mode", "enable"}); });
  EXPECT_NE(typo.find("did you mean 'enable'?"), std::string::npos) << typo;
}

TEST(Config, OverridesApplyBeforeValidation) {
  const auto path = std::filesystem::temp_directory_path() / "hpr_test_config.yaml";
  {
    std::ofstream f(path);
    f << kYaml;
  }
  const Config c = Config::load(path.string(), {"wbc.com.damping=40", "reference_gen.beta=0.4", "new.deep.key=[1, 2]"});
  EXPECT_DOUBLE_EQ(c.section("wbc").section("com").real("damping"), 40.0);
  EXPECT_DOUBLE_EQ(c.section("reference_gen").real("beta"), 0.4);
  EXPECT_EQ(c.section("new").section("deep").reals("key").size(), 2U);
  EXPECT_NE(error_of([&] { (void)Config::load(path.string(), {"novalue"}); }).find("not of the form key=value"),
            std::string::npos);
  std::filesystem::remove(path);
}

TEST(Config, MissingFileAndSyntaxErrorsNameTheFile) {
  EXPECT_NE(error_of([] { (void)Config::load("/nonexistent/x.yaml"); }).find("/nonexistent/x.yaml: configuration file not found"),
            std::string::npos);
  EXPECT_NE(error_of([] { (void)Config::parse("a: [1, 2\nb: 3\n", "bad.yaml"); }).find("bad.yaml:"), std::string::npos);
}

}  // namespace
