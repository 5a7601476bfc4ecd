#include "hpr/hal/cannelloni.hpp"

#include <fmt/format.h>

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace hpr::hal {

std::size_t cannelloni_encode(std::span<const CanFrame> frames, std::uint8_t sequence, std::span<std::uint8_t> out) {
  std::size_t n = 5;
  if (out.size() < n || frames.size() > 0xFFFF) return 0;
  out[0] = kCannelloniVersion;
  out[1] = kCannelloniOpData;
  out[2] = sequence;
  out[3] = static_cast<std::uint8_t>(frames.size() >> 8);
  out[4] = static_cast<std::uint8_t>(frames.size() & 0xFF);
  for (const CanFrame& f : frames) {
    const std::size_t need = 4 + 1 + (f.fd ? 1 : 0) + f.len;
    if (n + need > out.size() || f.len > 64) return 0;
    out[n++] = static_cast<std::uint8_t>(f.id >> 24);
    out[n++] = static_cast<std::uint8_t>(f.id >> 16);
    out[n++] = static_cast<std::uint8_t>(f.id >> 8);
    out[n++] = static_cast<std::uint8_t>(f.id);
    out[n++] = static_cast<std::uint8_t>(f.len | (f.fd ? 0x80 : 0x00));
    if (f.fd) out[n++] = f.flags;
    std::memcpy(&out[n], f.data.data(), f.len);
    n += f.len;
  }
  return n;
}

std::string cannelloni_decode(std::span<const std::uint8_t> d, std::vector<CanFrame>& out) {
  if (d.size() < 5) return "datagram of " + std::to_string(d.size()) + " bytes is shorter than the 5-byte header";
  if (d[0] != kCannelloniVersion) return "version " + std::to_string(d[0]) + " (expected 2)";
  if (d[1] != kCannelloniOpData) return "op code " + std::to_string(d[1]) + " (expected DATA = 0)";
  const std::size_t count = (static_cast<std::size_t>(d[3]) << 8) | d[4];
  const std::size_t first = out.size();
  std::size_t n = 5;
  for (std::size_t i = 0; i < count; ++i) {
    if (n + 5 > d.size()) {
      out.resize(first);
      return "truncated at frame " + std::to_string(i) + " of " + std::to_string(count);
    }
    CanFrame f;
    f.id = (static_cast<std::uint32_t>(d[n]) << 24) | (static_cast<std::uint32_t>(d[n + 1]) << 16) |
           (static_cast<std::uint32_t>(d[n + 2]) << 8) | d[n + 3];
    n += 4;
    const std::uint8_t len = d[n++];
    f.fd = (len & 0x80) != 0;
    f.len = len & 0x7F;
    if (f.fd) {
      if (n >= d.size()) {
        out.resize(first);
        return "truncated flags of frame " + std::to_string(i);
      }
      f.flags = d[n++];
    }
    if (f.len > (f.fd ? 64 : 8) || (f.fd && fd_length(f.len) != f.len)) {
      out.resize(first);
      return "frame " + std::to_string(i) + " has an invalid length " + std::to_string(f.len);
    }
    if (n + f.len > d.size()) {
      out.resize(first);
      return "truncated payload of frame " + std::to_string(i);
    }
    std::memcpy(f.data.data(), &d[n], f.len);
    n += f.len;
    out.push_back(f);
  }
  return {};
}

UdpEndpoint UdpEndpoint::parse(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon + 1 >= text.size()) throw std::invalid_argument("'" + text + "' is not host:port");
  UdpEndpoint e;
  e.host = text.substr(0, colon);
  try {
    std::size_t used = 0;
    e.port = std::stoi(text.substr(colon + 1), &used);
    if (used != text.size() - colon - 1 || e.port < 0 || e.port > 65535) throw std::invalid_argument("port");
  } catch (const std::exception&) {
    throw std::invalid_argument("'" + text + "': port is not a number in 0..65535");
  }
  return e;
}

namespace {
sockaddr_in resolve(const UdpEndpoint& e) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(e.port));
  if (e.host.empty() || e.host == "*") {
    a.sin_addr.s_addr = htonl(INADDR_ANY);
    return a;
  }
  if (inet_pton(AF_INET, e.host.c_str(), &a.sin_addr) == 1) return a;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  if (getaddrinfo(e.host.c_str(), nullptr, &hints, &res) != 0 || res == nullptr) {
    throw std::runtime_error("cannot resolve host '" + e.host + "'");
  }
  std::memcpy(&a.sin_addr, &reinterpret_cast<sockaddr_in*>(res->ai_addr)->sin_addr, sizeof(a.sin_addr));
  freeaddrinfo(res);
  return a;
}
}  // namespace

UdpCannelloniTransport::UdpCannelloniTransport(std::string name, const UdpEndpoint& local, const UdpEndpoint& remote)
    : name_(std::move(name)),
      local_text_(local.host + ":" + std::to_string(local.port)),
      remote_text_(remote.host + ":" + std::to_string(remote.port)),
      buffer_(65536) {
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error("bus " + name_ + ": socket: " + std::strerror(errno));
  const int one = 1;
  ::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  const int size = 1 << 20;
  ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &size, sizeof(size));
  const sockaddr_in l = resolve(local);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&l), sizeof(l)) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd_);
    throw std::runtime_error("bus " + name_ + ": cannot bind udp " + local_text_ + ": " + why);
  }
  const sockaddr_in r = resolve(remote);
  remote_addr_.resize(sizeof(r));
  std::memcpy(remote_addr_.data(), &r, sizeof(r));
  queue_.reserve(64);
}

UdpCannelloniTransport::~UdpCannelloniTransport() {
  if (fd_ >= 0) ::close(fd_);
}

bool UdpCannelloniTransport::send(const CanFrame& frame) {
  queue_.push_back(frame);
  return true;
}

void UdpCannelloniTransport::flush() {
  std::size_t begin = 0;
  while (begin < queue_.size()) {
    // As many frames as fit in one MTU-sized datagram.
    std::size_t end = begin, bytes = 5;
    while (end < queue_.size() && bytes + 6 + queue_[end].len <= kCannelloniMaxDatagram) bytes += 6 + queue_[end++].len;
    const std::size_t n = cannelloni_encode(std::span(queue_).subspan(begin, end - begin), sequence_++,
                                            std::span(buffer_).first(kCannelloniMaxDatagram));
    const auto sent = ::sendto(fd_, buffer_.data(), n, 0, reinterpret_cast<const sockaddr*>(remote_addr_.data()),
                               static_cast<socklen_t>(remote_addr_.size()));
    if (sent == static_cast<ssize_t>(n)) {
      counters_.tx_frames += static_cast<std::int64_t>(end - begin);
    } else {
      counters_.dropped += static_cast<std::int64_t>(end - begin);
      counters_.last_error = std::string("sendto ") + remote_text_ + ": " + std::strerror(errno);
    }
    begin = end;
  }
  queue_.clear();
}

int UdpCannelloniTransport::receive(std::vector<CanFrame>& out) {
  int got = 0;
  for (;;) {
    sockaddr_in from{};
    socklen_t from_len = sizeof from;
    const auto n = ::recvfrom(fd_, buffer_.data(), buffer_.size(), 0, reinterpret_cast<sockaddr*>(&from), &from_len);
    if (n < 0) break;  // EAGAIN: nothing more
    // Only the configured peer speaks for the bus: a datagram from any other address or port (a
    // forged reply, a forged error frame) is refused before it is read.
    sockaddr_in peer{};
    std::memcpy(&peer, remote_addr_.data(), sizeof peer);
    if (from.sin_family != AF_INET || from.sin_port != peer.sin_port ||
        (peer.sin_addr.s_addr != htonl(INADDR_ANY) && from.sin_addr.s_addr != peer.sin_addr.s_addr)) {
      ++counters_.foreign;
      ++counters_.errors;
      char host[INET_ADDRSTRLEN] = "?";
      (void)inet_ntop(AF_INET, &from.sin_addr, host, sizeof host);
      counters_.last_error = fmt::format("a datagram from {}:{} refused: the bus's peer is {}", host, ntohs(from.sin_port), remote_text_);
      continue;
    }
    const std::size_t before = out.size();
    const std::string why = cannelloni_decode(std::span<const std::uint8_t>(buffer_.data(), static_cast<std::size_t>(n)), out);
    if (!why.empty()) {
      ++malformed_;
      ++counters_.errors;
      counters_.last_error = "malformed datagram: " + why;
      continue;
    }
    // Error frames update the bus state and are not returned.
    std::size_t w = before;
    for (std::size_t i = before; i < out.size(); ++i) {
      if (!account_error_frame(out[i], counters_)) out[w++] = out[i];
    }
    out.resize(w);
    counters_.rx_frames += static_cast<std::int64_t>(w - before);
    got += static_cast<int>(w - before);
  }
  return got;
}

std::string UdpCannelloniTransport::describe() const { return "udp:" + local_text_ + "->" + remote_text_; }

}  // namespace hpr::hal
