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

// A process that has read its configuration refuses what it did not understand.
const char* kStack = R"(wbc:
  com:
    stiffness: 300
    stifness: 200
  mode: double
sim:
  dt: 0.001
)";

TEST(Config, AKeyNoCodeReadInAnEnteredSectionIsRefusedWithTheNearestName) {
  const Config c = Config::parse(kStack, "stack.yaml");
  const Config wbc = c.section("wbc");
  (void)wbc.section("com").real("stiffness");
  (void)wbc.string_or("mode", "single");
  const std::string msg = error_of([&] { c.check_all_read(); });
  EXPECT_NE(msg.find("stack.yaml:4: wbc.com.stifness: unknown key (did you mean 'stiffness'?)"), std::string::npos) << msg;
  // The sim section was not entered: another process's, not judged here.
  EXPECT_EQ(msg.find("sim"), std::string::npos) << msg;
}

TEST(Config, KeysReadAsOptionalEnumeratedRawOrKnownCountAsRead) {
  const Config c = Config::parse(kStack, "stack.yaml");
  const Config wbc = c.section("wbc");
  const Config com = wbc.section("com");
  (void)com.keys();                                   // enumerated: the caller judges each
  wbc.known({"mode"});                                // left to another process
  EXPECT_EQ(error_of([&] { c.check_all_read(); }), "");
  const Config c2 = Config::parse(kStack, "stack.yaml");
  (void)c2.section("wbc").yaml();                     // read as raw YAML
  EXPECT_EQ(error_of([&] { c2.check_all_read(); }), "");
  const Config c3 = Config::parse(kStack, "stack.yaml");
  (void)c3.section("wbc").has("mode");                // looked up counts, present or not
  const std::string msg = error_of([&] { c3.check_all_read(); });
  EXPECT_NE(msg.find("wbc.com: unknown key"), std::string::npos) << "a sub-section nobody entered or looked up: " << msg;
}

TEST(Config, AnOverrideOfAKeyNotReadIsRefusedUnlessItBelongsToAnotherProcess) {
  const auto path = std::filesystem::temp_directory_path() / "hpr_test_config_overrides.yaml";
  std::ofstream(path) << kStack;
  auto load_and_read = [&](const std::vector<std::string>& sets) {
    const Config c = Config::load(path.string(), sets);
    const Config com = c.section("wbc").section("com");
    (void)com.real("stiffness");
    (void)com.real_or("damping", 10.0);
    c.section("wbc").known({"mode"});
    com.known({"stifness"});
    c.check_all_read();
  };
  EXPECT_EQ(error_of([&] { load_and_read({"wbc.com.damping=40"}); }), "") << "an optional key read";
  EXPECT_EQ(error_of([&] { load_and_read({"sim.dt=0.002"}); }), "") << "another process's section";
  const std::string typo = error_of([&] { load_and_read({"wbc.com.dampin=40"}); });
  EXPECT_NE(typo.find("override wbc.com.dampin: unknown key (not read by this process) (did you mean 'damping'?)"), std::string::npos)
      << typo;
  const std::string section = error_of([&] { load_and_read({"smi.dt=0.002"}); });
  EXPECT_NE(section.find("override smi.dt: the file has no section 'smi' (did you mean 'sim'?)"), std::string::npos) << section;
  std::filesystem::remove(path);
}

TEST(Config, AFolderGivenAsTheFileSaysSo) {
  const std::string msg = error_of([] { (void)Config::load(std::filesystem::temp_directory_path().string()); });
  EXPECT_NE(msg.find("is a folder"), std::string::npos) << msg;
}

TEST(Config, MissingFileAndSyntaxErrorsNameTheFile) {
  EXPECT_NE(error_of([] { (void)Config::load("/nonexistent/x.yaml"); }).find("/nonexistent/x.yaml: configuration file not found"),
            std::string::npos);
  EXPECT_NE(error_of([] { (void)Config::parse("a: [1, 2\nb: 3\n", "bad.yaml"); }).find("bad.yaml:"), std::string::npos);
}

}  // namespace
