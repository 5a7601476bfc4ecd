#include "hpr/node/lcm_url.hpp"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <lcm/lcm-cpp.hpp>

#include "hpr/node/udpm.hpp"

namespace hpr::node {

std::string resolve_lcm_url(const std::string& explicit_url, const std::string& configured_url) {
  if (!explicit_url.empty()) return explicit_url;
  if (!configured_url.empty()) return configured_url;
  if (const char* env = std::getenv("LCM_DEFAULT_URL"); env != nullptr && *env != '\0') return env;
  return kDefaultLcmUrl;
}

void check_multicast_route(const std::string& url) {
  if (!is_udpm_url(url)) return;
  const UdpmUrl u = parse_udpm_url(url);  // throws LcmError naming a malformed part
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(u.port));
  addr.sin_addr = u.group_addr;
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) throw LcmError(fmt::format("LCM: cannot create a UDP socket: {}", std::strerror(errno)));
  const int rc = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
  const int err = errno;
  ::close(fd);
  if (rc != 0) {
    throw LcmError(fmt::format(
        "LCM cannot reach multicast group {}:{} ({}): there is no multicast route. Fix (as root): {}", u.group,
        u.port, std::strerror(err), kMulticastFixCommand));
  }
}

std::string with_receive_buffer(const std::string& url, int bytes) {
  if (!is_udpm_url(url) || url.find("recv_buf_size=") != std::string::npos) return url;
  return url + (url.find('?') == std::string::npos ? "?" : "&") + "recv_buf_size=" + std::to_string(bytes);
}

std::unique_ptr<lcm::LCM> open_lcm(const std::string& url) {
  check_multicast_route(url);
  auto lcm = std::make_unique<lcm::LCM>(with_receive_buffer(url));
  if (!lcm->good()) {
    throw LcmError(fmt::format("LCM could not be opened on '{}'. If this is a multicast problem, fix (as root): {}",
                               url, kMulticastFixCommand));
  }
  return lcm;
}

}  // namespace hpr::node
