// The authentication codes of the commands and the clocked channels: libsodium's keyed BLAKE2b-256 checked against
// Python's independent implementation (hashlib.blake2b, from the BLAKE2 reference code), any
// changed bit refused, and the key file's rules (created whole once, mode 0600, refused when
// open to others or of the wrong size, with the file named).
#include <gtest/gtest.h>
#include <map>

#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/hal_status_t.hpp>
#include <humanoid/health_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/sim_truth_t.hpp>
#include <humanoid/supervisor_command_t.hpp>
#include <humanoid/supervisor_status_t.hpp>
#include <humanoid/wholebody_command_t.hpp>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "hpr/common/auth.hpp"
#include "process_group.hpp"

namespace {

using hpr::auth::AuthError;
using hpr::auth::Key;

std::vector<std::uint8_t> from_hex(const std::string& h) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i + 1 < h.size(); i += 2) out.push_back(static_cast<std::uint8_t>(std::stoi(h.substr(i, 2), nullptr, 16)));
  return out;
}

/// The key 00 01 02 ... 1f.
Key counting_key() {
  Key k;
  for (std::size_t i = 0; i < k.bytes.size(); ++i) k.bytes[i] = static_cast<std::uint8_t>(i);
  return k;
}

/// `bytes` followed by room for the code, signed for `channel` with counting_key(); returns the code.
std::vector<std::uint8_t> code_of(std::string_view channel, std::vector<std::uint8_t> bytes) {
  bytes.resize(bytes.size() + hpr::auth::kTagBytes);
  hpr::auth::sign(bytes.data(), bytes.size(), channel, counting_key());
  EXPECT_TRUE(hpr::auth::verify(bytes.data(), bytes.size(), channel, counting_key()));
  return {bytes.end() - hpr::auth::kTagBytes, bytes.end()};
}

// Every message a process acts on carries a code: the commands, every clocked channel of the
// control chain (a forged or corrupted sample is as dangerous as a forged command), and the reports
// the supervisors act on (HEALTH, SUPERVISOR_STATUS). PARAMS (read by the operator tool) and the
// simulator's test push are not signed.
static_assert(hpr::auth::Signed<humanoid::joint_command_t>);
static_assert(hpr::auth::Signed<humanoid::operator_t>);
static_assert(hpr::auth::Signed<humanoid::supervisor_command_t>);
static_assert(hpr::auth::Signed<humanoid::robot_sensors_t>);
static_assert(hpr::auth::Signed<humanoid::robot_state_t>);
static_assert(hpr::auth::Signed<humanoid::balance_status_t>);
static_assert(hpr::auth::Signed<humanoid::cam_reference_t>);
static_assert(hpr::auth::Signed<humanoid::wholebody_command_t>);
static_assert(hpr::auth::Signed<humanoid::sim_truth_t>);
static_assert(hpr::auth::Signed<humanoid::hal_status_t>);
static_assert(hpr::auth::Signed<humanoid::health_t>);  // the supervisor acts on it
static_assert(hpr::auth::Signed<humanoid::supervisor_status_t>);

TEST(Auth, TheCodeIsKeyedBlake2b256AsAnIndependentImplementationComputesIt) {
  // The code covers the channel's length (one byte), its name, then the message:
  // python3 -c "import hashlib; print(hashlib.blake2b(bytes([len(CH)]) + CH + MSG, key=bytes(range(32)),
  //                                                   digest_size=32).hexdigest())"
  const std::string hi = "Hi There";
  EXPECT_EQ(code_of("JOINT_COMMAND", {hi.begin(), hi.end()}), from_hex("42ea0cc07321559af14552b1d5e25f446f0d149884a87d84f3d9d7f64a1a68b5"));
  std::vector<std::uint8_t> counting(200);
  for (std::size_t i = 0; i < counting.size(); ++i) counting[i] = static_cast<std::uint8_t>(i);
  EXPECT_EQ(code_of("OPERATOR", counting), from_hex("11a867b7ee4c40111036fee294cb1e9a809ed1737972380851ccf1cffbe4b36d"));
}

TEST(Auth, EveryFlippedBitAnotherKeyAndATruncatedMessageAreRefused) {
  std::vector<std::uint8_t> msg(200);
  for (std::size_t i = 0; i < msg.size(); ++i) msg[i] = static_cast<std::uint8_t>(i * 37);
  const Key key = counting_key();
  hpr::auth::sign(msg.data(), msg.size(), "JOINT_COMMAND", key);
  ASSERT_TRUE(hpr::auth::verify(msg.data(), msg.size(), "JOINT_COMMAND", key));
  int accepted = 0;
  for (std::size_t i = 0; i < msg.size(); ++i) {
    for (int b = 0; b < 8; ++b) {
      msg[i] ^= static_cast<std::uint8_t>(1U << b);
      accepted += hpr::auth::verify(msg.data(), msg.size(), "JOINT_COMMAND", key) ? 1 : 0;
      msg[i] ^= static_cast<std::uint8_t>(1U << b);
    }
  }
  EXPECT_EQ(accepted, 0) << "of " << msg.size() * 8 << " single-bit changes";
  Key other = key;
  other.bytes[31] ^= 1;
  EXPECT_FALSE(hpr::auth::verify(msg.data(), msg.size(), "JOINT_COMMAND", other));
  EXPECT_FALSE(hpr::auth::verify(msg.data(), msg.size() - 1, "JOINT_COMMAND", key));
  EXPECT_FALSE(hpr::auth::verify(msg.data(), 10, "JOINT_COMMAND", key));
}

TEST(Auth, AMessageSignedForOneChannelIsRefusedOnAnother) {
  // Another channel, or the same one under another stack's prefix (two stacks sharing one key).
  std::vector<std::uint8_t> msg(120, 0x5a);
  const Key key = counting_key();
  hpr::auth::sign(msg.data(), msg.size(), "a/JOINT_COMMAND", key);
  EXPECT_TRUE(hpr::auth::verify(msg.data(), msg.size(), "a/JOINT_COMMAND", key));
  for (std::string_view other : {"JOINT_COMMAND", "b/JOINT_COMMAND", "a/JOINT_COMMANDS", "a/OPERATOR", ""}) {
    EXPECT_FALSE(hpr::auth::verify(msg.data(), msg.size(), other, key)) << other;
  }
}

TEST(AuthKey, CreatedOnceWithMode0600AndTheSameKeyForEveryCreatorAtOnce) {
  const std::string dir = hpr::test::temp_dir("auth-key") + "/new/folder";
  const std::string path = dir + "/lcm.key";
  // Eight processes race to create it: all end with one key, written whole.
  std::vector<pid_t> children;
  for (int i = 0; i < 8; ++i) {
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      try {
        const Key k = hpr::auth::load_or_create_key(path);
        std::ofstream(path + ".seen." + std::to_string(::getpid()), std::ios::binary)
            .write(reinterpret_cast<const char*>(k.bytes.data()), static_cast<std::streamsize>(k.bytes.size()));
        ::_exit(0);
      } catch (...) {
        ::_exit(1);
      }
    }
    children.push_back(pid);
  }
  for (const pid_t pid : children) {
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  const Key key = hpr::auth::load_key(path);
  std::set<std::string> seen;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("lcm.key.seen.", 0) != 0) {
      EXPECT_EQ(name, "lcm.key") << "a temporary file was left behind";
      continue;
    }
    std::ifstream f(e.path(), std::ios::binary);
    seen.insert(std::string(std::istreambuf_iterator<char>(f), {}));
  }
  ASSERT_EQ(seen.size(), 1U);
  EXPECT_EQ(*seen.begin(), std::string(key.bytes.begin(), key.bytes.end()));
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600U);
  EXPECT_EQ(st.st_size, 32);
  EXPECT_NE(key.bytes, Key{}.bytes);
}

std::string error_of(const std::string& path) {
  try {
    (void)hpr::auth::load_key(path);
  } catch (const AuthError& e) {
    return e.what();
  }
  return {};
}

TEST(AuthKey, AFileOpenToOthersOfTheWrongSizeOrMissingIsRefusedNamingIt) {
  const std::string dir = hpr::test::temp_dir("auth-key-bad") + "/hpr";
  const std::string path = dir + "/lcm.key";
  EXPECT_NE(error_of(path).find(path + " does not exist"), std::string::npos) << error_of(path);
  EXPECT_NE(error_of(path).find("supervisor"), std::string::npos) << error_of(path);
  (void)hpr::auth::load_or_create_key(path);
  ASSERT_EQ(::chmod(path.c_str(), 0644), 0);
  EXPECT_NE(error_of(path).find(path + ": open to others (mode 0644): chmod 600"), std::string::npos) << error_of(path);
  ASSERT_EQ(::chmod(path.c_str(), 0600), 0);
  EXPECT_EQ(error_of(path), "");
  std::ofstream(path, std::ios::app) << "x";
  EXPECT_NE(error_of(path).find(path + ": holds 33 bytes, a key is 32"), std::string::npos) << error_of(path);
}

// Where the key lives: not a symbolic link, not in a folder others may open or that is not the
// user's, never in a shared folder when the environment names none.
TEST(AuthKey, ASymlinkAFolderOpenToOthersAndNoHomeAreRefused) {
  const std::string base = hpr::test::temp_dir("auth-key-where");
  const std::string dir = base + "/hpr";
  const std::string path = dir + "/lcm.key";
  (void)hpr::auth::load_or_create_key(path);
  struct stat st {};
  ASSERT_EQ(::stat(dir.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0700U) << "the key's folder is created 0700";
  ASSERT_EQ(::chmod(dir.c_str(), 0755), 0);
  EXPECT_NE(error_of(path).find("its folder " + dir + " is open to others (mode 0755): chmod 700"), std::string::npos) << error_of(path);
  ASSERT_EQ(::chmod(dir.c_str(), 0700), 0);
  EXPECT_EQ(error_of(path), "");
  const std::string link = dir + "/link.key";
  ASSERT_EQ(::symlink(path.c_str(), link.c_str()), 0);
  EXPECT_NE(error_of(link).find("a symbolic link"), std::string::npos) << error_of(link);
  const std::string linked_dir = base + "/linked";
  ASSERT_EQ(::symlink(dir.c_str(), linked_dir.c_str()), 0);
  const std::string through_link = linked_dir + "/lcm.key";
  EXPECT_NE(error_of(through_link).find("is not a folder"), std::string::npos) << error_of(through_link);
  if (::geteuid() == 0) {
    // Another user's file (root can make one): refused even with the right mode.
    ASSERT_EQ(::chown(path.c_str(), 65534, 65534), 0);
    EXPECT_NE(error_of(path).find("belongs to uid 65534"), std::string::npos) << error_of(path);
    ASSERT_EQ(::chown(path.c_str(), 0, 0), 0);
  }
  // Without HPR_LCM_KEY_FILE, XDG_CONFIG_HOME and HOME there is no key path (no /tmp fallback).
  std::map<std::string, std::string> saved;
  for (const char* v : {"HPR_LCM_KEY_FILE", "XDG_CONFIG_HOME", "HOME"}) {
    if (const char* x = std::getenv(v)) saved[v] = x;
    ::unsetenv(v);
  }
  EXPECT_THROW((void)hpr::auth::key_path(), AuthError);
  for (const auto& [k, v] : saved) ::setenv(k.c_str(), v.c_str(), 1);
}

}  // namespace
