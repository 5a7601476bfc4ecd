#pragma once
/// \file A raw UDP sender to a udpm URL's multicast group and port (TTL 0): datagrams that liblcm
/// would not send (a foreign format, forged fragments), as anyone on the group could.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "hpr/node/udpm.hpp"

namespace hpr::test {

class MulticastSender {
 public:
  explicit MulticastSender(const std::string& url) : fd_(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0)) {
    const auto addr = hpr::node::parse_udpm_url(url);
    unsigned char ttl = 0;
    ::setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
    to_.sin_family = AF_INET;
    to_.sin_port = htons(static_cast<std::uint16_t>(addr.port));
    to_.sin_addr = addr.group_addr;
  }
  ~MulticastSender() {
    if (fd_ >= 0) ::close(fd_);
  }
  MulticastSender(const MulticastSender&) = delete;
  MulticastSender& operator=(const MulticastSender&) = delete;
  [[nodiscard]] bool good() const { return fd_ >= 0; }
  /// Sends one datagram; whether it all went.
  bool send(const void* data, std::size_t size) {
    return ::sendto(fd_, data, size, 0, reinterpret_cast<const sockaddr*>(&to_), sizeof to_) == static_cast<ssize_t>(size);
  }

 private:
  int fd_ = -1;
  sockaddr_in to_{};
};

}  // namespace hpr::test
