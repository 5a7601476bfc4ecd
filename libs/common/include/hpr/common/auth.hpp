#pragma once
/// \file
/// Message authentication for every message a process acts on: the commands (OPERATOR,
/// JOINT_COMMAND, SUPERVISOR_COMMAND) and every clocked channel of the control chain (ROBOT_SENSORS,
/// ROBOT_STATE, BALANCE_PLAN, BALANCE_STATUS, CAM_REFERENCE, WHOLEBODY_COMMAND, SIM_TRUTH, HAL_STATUS). A keyed
/// hash over a message's encoded bytes with a per-deployment key, so that only holders of the key
/// command the robot or feed its controllers: a forged or corrupted sample is refused before it is
/// decoded, whatever it holds. The hash is keyed BLAKE2b with a 256-bit output
/// (libsodium's crypto_generichash with a 32-byte key, its documented MAC use): about 3 us to sign
/// or check a 27-joint JOINT_COMMAND where HMAC-SHA-512-256 (crypto_auth) took 12 us (bench_auth).
///
/// A signed type declares `byte mac[32]` as its last field: the encoded message's last 32 bytes are
/// the code over the channel's full name and every byte before them (the LCM fingerprint
/// included), so that a message is only valid on the channel it was signed for. lcm-spy and the log tools
/// decode such a message like any other; the code is only checked by the processes that act on it.
///
/// The key is a file of 32 random bytes, readable by its owner only (mode 0600), owned by the
/// process's user, not a symbolic link, in a folder of that user's that no one else may open (0700):
/// the one named by $HPR_LCM_KEY_FILE, else `${XDG_CONFIG_HOME:-$HOME/.config}/hpr/lcm.key` (with
/// none of the three set, there is no key file: never a shared folder). The supervisor creates it
/// on first `up`; every host of a deployment holds a copy.

#include <array>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

namespace hpr::auth {

inline constexpr std::size_t kKeyBytes = 32;
inline constexpr std::size_t kTagBytes = 32;

/// A key file that is missing, unreadable, of the wrong size or readable by others.
class AuthError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Key {
  std::array<std::uint8_t, kKeyBytes> bytes{};
  std::string path;  ///< the file it was read from
};

/// The deployment's key file: $HPR_LCM_KEY_FILE, else ${XDG_CONFIG_HOME:-$HOME/.config}/hpr/lcm.key;
/// throws AuthError when none of them is set.
[[nodiscard]] std::string key_path();

/// Reads the key at `path`; throws AuthError naming the file and what is wrong with it (missing, a
/// symbolic link, another user's, open to others, its folder another user's or open to others; how
/// to create one when it is missing).
[[nodiscard]] Key load_key(const std::string& path);

/// Reads the key at `path`, creating it first (32 random bytes, mode 0600, its folder 0700) when
/// there is none. Safe against concurrent creators: the file appears whole or not at all, and every
/// caller ends up with the same key.
[[nodiscard]] Key load_or_create_key(const std::string& path);

/// Writes the code of the message `bytes[0, n - kTagBytes)` published on `channel` (its full name,
/// prefix included) into the last kTagBytes of `bytes` (n >= kTagBytes).
void sign(std::uint8_t* bytes, std::size_t n, std::string_view channel, const Key& key);

/// Whether the last kTagBytes of `bytes` are the code of the bytes before them on `channel`
/// (constant time). A message signed for another channel, or another stack's prefix, does not verify.
[[nodiscard]] bool verify(const std::uint8_t* bytes, std::size_t n, std::string_view channel, const Key& key);

/// An lcm-gen type that carries a code: `byte mac[32]` as its last field.
template <class Msg>
concept Signed = requires(const Msg& m) { m.mac; } &&
                 std::is_same_v<std::remove_cvref_t<decltype(std::declval<const Msg&>().mac)>, std::uint8_t[kTagBytes]>;

}  // namespace hpr::auth
