#include "hpr/common/auth.hpp"

#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>
#include <fcntl.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>

namespace hpr::auth {
namespace {

static_assert(crypto_generichash_KEYBYTES_MAX >= kKeyBytes && crypto_generichash_KEYBYTES_MIN <= kKeyBytes &&
              crypto_generichash_BYTES_MIN <= kTagBytes && crypto_generichash_BYTES_MAX >= kTagBytes);

void init_sodium() {
  static const bool ok = sodium_init() >= 0;
  if (!ok) throw AuthError("libsodium could not be initialised (sodium_init failed)");
}

std::string errno_text() { return std::strerror(errno); }

const char* kCreateHint =
    "the supervisor creates it on `tools/supervisor up`; `tools/supervisor keygen` creates it alone; "
    "on another host of the deployment, copy it there (mode 0600); a bench without authentication "
    "sets lcm.authentication: off";

}  // namespace

std::string key_path() {
  if (const char* p = std::getenv("HPR_LCM_KEY_FILE"); p != nullptr && *p != '\0') return p;
  std::filesystem::path base;
  if (const char* x = std::getenv("XDG_CONFIG_HOME"); x != nullptr && *x != '\0') {
    base = x;
  } else if (const char* h = std::getenv("HOME"); h != nullptr && *h != '\0') {
    base = std::filesystem::path(h) / ".config";
  } else {
    // No fallback to a shared folder (/tmp): another user could put a key of theirs there.
    throw AuthError("no LCM key file: neither HPR_LCM_KEY_FILE, XDG_CONFIG_HOME nor HOME is set");
  }
  return (base / "hpr" / "lcm.key").lexically_normal().string();
}

Key load_key(const std::string& path) {
  init_sodium();
  // Its folder first: a folder others may write to lets them swap the file.
  const std::string dir = std::filesystem::path(path).parent_path().string();
  struct stat ds {};
  if (::lstat(dir.empty() ? "." : dir.c_str(), &ds) != 0) {
    if (errno == ENOENT) throw AuthError("LCM key file " + path + " does not exist: " + kCreateHint);
    throw AuthError("LCM key file " + path + ": cannot stat its folder (" + errno_text() + ")");
  }
  if (!S_ISDIR(ds.st_mode)) throw AuthError("LCM key file " + path + ": its folder " + dir + " is not a folder (a symbolic link?)");
  if (ds.st_uid != ::geteuid()) {
    throw AuthError("LCM key file " + path + ": its folder " + dir + " belongs to uid " + std::to_string(ds.st_uid) +
                    ", not to this process's user (uid " + std::to_string(::geteuid()) + ")");
  }
  if ((ds.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(ds.st_mode & 07777));
    throw AuthError("LCM key file " + path + ": its folder " + dir + " is open to others (mode " + mode + "): chmod 700 " + dir);
  }
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) {
    if (errno == ENOENT) throw AuthError("LCM key file " + path + " does not exist: " + kCreateHint);
    if (errno == ELOOP) throw AuthError("LCM key file " + path + ": a symbolic link (a key file is the file itself)");
    throw AuthError("LCM key file " + path + ": cannot open (" + errno_text() + ")");
  }
  struct stat st {};
  Key key;
  key.path = path;
  std::string why;
  if (::fstat(fd, &st) != 0) {
    why = "cannot stat (" + errno_text() + ")";
  } else if (!S_ISREG(st.st_mode)) {
    why = "not a regular file";
  } else if (st.st_uid != ::geteuid()) {
    why = "belongs to uid " + std::to_string(st.st_uid) + ", not to this process's user (uid " + std::to_string(::geteuid()) + ")";
  } else if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    why = std::string("open to others (mode ") + mode + "): chmod 600 " + path;
  } else if (st.st_size != static_cast<off_t>(kKeyBytes)) {
    why = "holds " + std::to_string(st.st_size) + " bytes, a key is " + std::to_string(kKeyBytes);
  } else if (::read(fd, key.bytes.data(), kKeyBytes) != static_cast<ssize_t>(kKeyBytes)) {
    why = "cannot read (" + errno_text() + ")";
  }
  ::close(fd);
  if (!why.empty()) throw AuthError("LCM key file " + path + ": " + why);
  return key;
}

Key load_or_create_key(const std::string& path) {
  init_sodium();
  if (::access(path.c_str(), F_OK) == 0) return load_key(path);
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(path).parent_path();
  std::error_code ec;
  if (!dir.empty() && !fs::exists(dir)) {
    // The parents as the umask says, the key's own folder 0700 from its creation (never open for
    // a moment, whoever creates it at the same time).
    if (dir.has_parent_path()) fs::create_directories(dir.parent_path(), ec);
    if (ec) throw AuthError("LCM key file " + path + ": cannot create " + dir.parent_path().string() + " (" + ec.message() + ")");
    if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) {
      throw AuthError("LCM key file " + path + ": cannot create " + dir.string() + " (" + errno_text() + ")");
    }
  }
  // Written whole under a unique name, then linked to its place: link() fails if another process
  // got there first, and then both use that one.
  const std::string tmp = path + ".new." + std::to_string(::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) throw AuthError("LCM key file " + path + ": cannot create " + tmp + " (" + errno_text() + ")");
  std::array<std::uint8_t, kKeyBytes> bytes{};
  randombytes_buf(bytes.data(), bytes.size());
  const bool written = ::write(fd, bytes.data(), kKeyBytes) == static_cast<ssize_t>(kKeyBytes) && ::fsync(fd) == 0;
  ::close(fd);
  sodium_memzero(bytes.data(), bytes.size());
  if (!written) {
    ::unlink(tmp.c_str());
    throw AuthError("LCM key file " + path + ": cannot write " + tmp + " (" + errno_text() + ")");
  }
  const int linked = ::link(tmp.c_str(), path.c_str());
  const int link_errno = errno;
  ::unlink(tmp.c_str());
  if (linked != 0 && link_errno != EEXIST) {
    errno = link_errno;
    throw AuthError("LCM key file " + path + ": cannot create (" + errno_text() + ")");
  }
  return load_key(path);
}

namespace {

/// The code of `channel` and `bytes[0, n)`: the channel's length (one byte: LCM names have at most
/// 63) and name first, so that a message signed for one channel does not verify on another.
void code(std::uint8_t* out, std::string_view channel, const std::uint8_t* bytes, std::size_t n, const Key& key) {
  crypto_generichash_state state;
  crypto_generichash_init(&state, key.bytes.data(), kKeyBytes, kTagBytes);
  const auto length = static_cast<std::uint8_t>(std::min<std::size_t>(channel.size(), 255));
  crypto_generichash_update(&state, &length, 1);
  crypto_generichash_update(&state, reinterpret_cast<const unsigned char*>(channel.data()), length);
  crypto_generichash_update(&state, bytes, n);
  crypto_generichash_final(&state, out, kTagBytes);
}

}  // namespace

void sign(std::uint8_t* bytes, std::size_t n, std::string_view channel, const Key& key) {
  if (n < kTagBytes) return;
  code(bytes + n - kTagBytes, channel, bytes, n - kTagBytes, key);
}

bool verify(const std::uint8_t* bytes, std::size_t n, std::string_view channel, const Key& key) {
  if (n < kTagBytes) return false;
  std::array<std::uint8_t, kTagBytes> expected{};
  code(expected.data(), channel, bytes, n - kTagBytes, key);
  return crypto_verify_32(expected.data(), bytes + n - kTagBytes) == 0;
}

}  // namespace hpr::auth
