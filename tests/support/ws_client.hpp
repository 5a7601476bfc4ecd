#pragma once
/// \file Integration-test support: a minimal WebSocket client (RFC 6455) over a blocking TCP socket,
/// written independently of the server's library so that the tests check the wire format itself.
/// Text and binary frames, client frames masked, no fragmentation or extensions.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>

namespace hpr::test {

/// An HTTP/1.1 GET on 127.0.0.1:port; returns the whole response (status line, headers, body).
inline std::string http_get(int port, const std::string& path, int timeout_ms = 5000) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    throw std::runtime_error("cannot connect to port " + std::to_string(port));
  }
  const std::string req = "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
  if (::send(fd, req.data(), req.size(), MSG_NOSIGNAL) < 0) {
    ::close(fd);
    throw std::runtime_error("send failed");
  }
  std::string out;
  char buf[65536];
  for (;;) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) <= 0) break;
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    out.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return out;
}

/// The body of an HTTP response.
inline std::string http_body(const std::string& response) {
  const auto p = response.find("\r\n\r\n");
  return p == std::string::npos ? std::string() : response.substr(p + 4);
}

class WsClient {
 public:
  struct Frame {
    int opcode = -1;  ///< 1 text, 2 binary, 8 close; -1 nothing within the timeout
    std::string payload;
  };

  /// Connects and performs the opening handshake asking for `subprotocol` (empty: none).
  /// `rcvbuf` > 0 sets the socket's receive buffer (a slow client: a small window).
  WsClient(int port, const std::string& subprotocol, int rcvbuf = 0) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    if (rcvbuf > 0) ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("cannot connect");
    std::string req = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n";
    if (!subprotocol.empty()) req += "Sec-WebSocket-Protocol: " + subprotocol + "\r\n";
    req += "\r\n";
    send_all(req);
    // The response headers, byte by byte up to the blank line (frames may follow at once).
    while (response_.size() < 4 || response_.compare(response_.size() - 4, 4, "\r\n\r\n") != 0) {
      char c = 0;
      if (!wait_readable(5000) || ::recv(fd_, &c, 1, 0) != 1) break;
      response_.push_back(c);
    }
  }
  ~WsClient() {
    if (fd_ >= 0) ::close(fd_);
  }
  WsClient(const WsClient&) = delete;
  WsClient& operator=(const WsClient&) = delete;

  /// The handshake response's headers.
  [[nodiscard]] const std::string& response() const { return response_; }
  [[nodiscard]] bool upgraded() const { return response_.rfind("HTTP/1.1 101", 0) == 0; }

  /// Sends a masked text frame.
  void send_text(const std::string& text) {
    std::string f;
    f.push_back(static_cast<char>(0x81));
    const std::size_t n = text.size();
    if (n < 126) {
      f.push_back(static_cast<char>(0x80 | n));
    } else if (n < 65536) {
      f.push_back(static_cast<char>(0x80 | 126));
      f.push_back(static_cast<char>((n >> 8) & 0xff));
      f.push_back(static_cast<char>(n & 0xff));
    } else {
      f.push_back(static_cast<char>(0x80 | 127));
      for (int b = 7; b >= 0; --b) f.push_back(static_cast<char>((n >> (8 * b)) & 0xff));
    }
    unsigned char mask[4];
    for (auto& m : mask) m = static_cast<unsigned char>(gen_() & 0xff);
    f.append(reinterpret_cast<const char*>(mask), 4);
    for (std::size_t i = 0; i < n; ++i) f.push_back(static_cast<char>(text[i] ^ static_cast<char>(mask[i % 4])));
    send_all(f);
  }

  /// The next frame, or opcode -1 after `timeout_ms` without one.
  Frame read(int timeout_ms = 5000) {
    Frame fr;
    unsigned char h[2];
    if (!read_exact(h, 2, timeout_ms)) return fr;
    fr.opcode = h[0] & 0x0f;
    std::uint64_t n = h[1] & 0x7f;
    if (n == 126) {
      unsigned char e[2];
      if (!read_exact(e, 2, timeout_ms)) return {};
      n = (static_cast<std::uint64_t>(e[0]) << 8) | e[1];
    } else if (n == 127) {
      unsigned char e[8];
      if (!read_exact(e, 8, timeout_ms)) return {};
      n = 0;
      for (unsigned char b : e) n = (n << 8) | b;
    }
    if ((h[1] & 0x80) != 0) throw std::runtime_error("a server frame is masked");
    fr.payload.resize(n);
    if (n > 0 && !read_exact(reinterpret_cast<unsigned char*>(fr.payload.data()), n, timeout_ms)) return {};
    return fr;
  }

 private:
  bool wait_readable(int timeout_ms) {
    pollfd p{fd_, POLLIN, 0};
    return ::poll(&p, 1, timeout_ms) > 0;
  }
  bool read_exact(unsigned char* out, std::size_t n, int timeout_ms) {
    std::size_t got = 0;
    while (got < n) {
      if (!wait_readable(timeout_ms)) return false;
      const ssize_t r = ::recv(fd_, out + got, n - got, 0);
      if (r <= 0) return false;
      got += static_cast<std::size_t>(r);
    }
    return true;
  }
  void send_all(const std::string& s) {
    std::size_t sent = 0;
    while (sent < s.size()) {
      const ssize_t n = ::send(fd_, s.data() + sent, s.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) throw std::runtime_error("send failed");
      sent += static_cast<std::size_t>(n);
    }
  }

  int fd_ = -1;
  std::string response_;
  std::mt19937 gen_{12345};
};

}  // namespace hpr::test
