#include "hpr/node/udpm.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>

#include "hpr/node/lcm_url.hpp"

namespace hpr::node {

namespace {

constexpr std::uint32_t kMagicShort = 0x4c433032;  // "LC02"
constexpr std::uint32_t kMagicLong = 0x4c433033;   // "LC03"
constexpr std::size_t kShortHeader = 8;
constexpr std::size_t kLongHeader = 20;
constexpr std::size_t kMaxDatagram = 65536;

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}
std::uint16_t be16(const std::uint8_t* p) { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }

/// The channel name that starts at `p` (at most `n` bytes, NUL-terminated); empty with `why` set
/// when there is none.
std::string_view channel_at(const std::uint8_t* p, std::size_t n, std::string& why) {
  const auto* end = static_cast<const std::uint8_t*>(std::memchr(p, 0, std::min(n, LcmDatagrams::kMaxChannelLength + 1)));
  if (end == nullptr) {
    why = n <= LcmDatagrams::kMaxChannelLength ? "the channel name is not terminated"
                                               : fmt::format("the channel name is longer than {} bytes", LcmDatagrams::kMaxChannelLength);
    return {};
  }
  if (end == p) {
    why = "the channel name is empty";
    return {};
  }
  return {reinterpret_cast<const char*>(p), static_cast<std::size_t>(end - p)};
}

int parse_int(const std::string& url, std::string_view what, std::string_view text, int lo, int hi) {
  int v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || end != text.data() + text.size() || v < lo || v > hi) {
    throw LcmError(fmt::format("LCM URL '{}': {} '{}' is not a number in [{}, {}]", url, what, text, lo, hi));
  }
  return v;
}

}  // namespace

bool is_udpm_url(const std::string& url) { return url.rfind("udpm://", 0) == 0; }

UdpmUrl parse_udpm_url(const std::string& url) {
  if (!is_udpm_url(url)) throw LcmError(fmt::format("LCM URL '{}' is not a udpm:// URL", url));
  UdpmUrl u;
  std::string_view rest(url);
  rest.remove_prefix(7);
  std::string_view query;
  if (const auto q = rest.find('?'); q != std::string_view::npos) {
    query = rest.substr(q + 1);
    rest = rest.substr(0, q);
  }
  if (const auto colon = rest.find(':'); colon != std::string_view::npos) {
    u.port = parse_int(url, "the port", rest.substr(colon + 1), 1, 65535);
    rest = rest.substr(0, colon);
  }
  if (!rest.empty()) u.group = std::string(rest);
  if (inet_pton(AF_INET, u.group.c_str(), &u.group_addr) != 1 || !IN_MULTICAST(ntohl(u.group_addr.s_addr))) {
    throw LcmError(fmt::format("LCM URL '{}': '{}' is not an IPv4 multicast address", url, u.group));
  }
  while (!query.empty()) {
    const auto amp = query.find('&');
    const std::string_view kv = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view{} : query.substr(amp + 1);
    if (kv.rfind("recv_buf_size=", 0) == 0) u.recv_buf_size = parse_int(url, "recv_buf_size", kv.substr(14), 0, 1 << 30);
  }
  return u;
}

std::string LcmDatagrams::feed(const std::uint8_t* data, std::size_t size, std::uint64_t sender, std::int64_t utime,
                               const MessageSink& sink) {
  if (size < kShortHeader) return fmt::format("{} bytes, shorter than any LCM header", size);
  const std::uint32_t magic = be32(data);
  if (magic == kMagicLong) return feed_fragment(data, size, sender, utime, sink);
  if (magic != kMagicShort) return fmt::format("magic 0x{:08x} is not LCM's", magic);
  std::string why;
  const std::string_view channel = channel_at(data + kShortHeader, size - kShortHeader, why);
  if (channel.empty()) return why;
  const std::size_t start = kShortHeader + channel.size() + 1;
  sink(channel, data + start, size - start, utime);
  return {};
}

std::string LcmDatagrams::feed_fragment(const std::uint8_t* data, std::size_t size, std::uint64_t sender, std::int64_t utime,
                                        const MessageSink& sink) {
  if (size < kLongHeader) return fmt::format("fragment of {} bytes, shorter than its {}-byte header", size, kLongHeader);
  const std::uint32_t seqno = be32(data + 4);
  const std::uint32_t total = be32(data + 8);
  const std::uint32_t offset = be32(data + 12);
  const std::uint16_t no = be16(data + 16);
  const std::uint16_t count = be16(data + 18);
  if (total == 0 || total > kMaxMessageBytes) return fmt::format("fragmented message of {} bytes (at most {})", total, kMaxMessageBytes);
  if (count < 2 || no >= count) return fmt::format("fragment {} of {}", no, count);
  const std::uint8_t* body = data + kLongHeader;
  std::size_t n = size - kLongHeader;
  std::string why;
  std::string_view channel;
  if (no == 0) {
    if (offset != 0) return fmt::format("fragment 0 at offset {}", offset);
    channel = channel_at(body, n, why);
    if (channel.empty()) return why;
    body += channel.size() + 1;
    n -= channel.size() + 1;
  }
  if (std::size_t{offset} + n > total) return fmt::format("fragment {} ends at {}, beyond the message's {} bytes", no, std::size_t{offset} + n, total);
  auto it = partial_.find(sender);
  if (it == partial_.end() || it->second.fragments == 0 || it->second.seqno != seqno || it->second.size != total ||
      it->second.fragments != count) {
    // A new message: only from its first fragment, on a channel read, within its limit and the rate.
    if (no != 0) return fmt::format("fragment {} of {} of message {} before its first: refused", no, count, seqno);
    if (std::string refused = refuse_new(channel, total, utime); !refused.empty()) return refused;
    // The sender's unfinished one goes, and every other one too if together they would hold more
    // than the budget.
    if (it != partial_.end()) {
      if (it->second.fragments != 0 && it->second.missing > 0) ++dropped_partial_;
      partial_bytes_ -= it->second.payload.size();
      partial_.erase(it);
    }
    if (partial_bytes_ + total > budget_) {
      for (const auto& [s, q] : partial_) dropped_partial_ += q.fragments != 0 && q.missing > 0 ? 1 : 0;
      partial_.clear();
      partial_bytes_ = 0;
    }
    it = partial_.try_emplace(sender).first;
    Partial& p = it->second;
    p.seqno = seqno;
    p.size = total;
    p.fragments = count;
    p.missing = count;
    p.channel.clear();
    p.payload.assign(total, 0);
    p.seen.assign(count, false);
    partial_bytes_ += total;
    peak_partial_bytes_ = std::max(peak_partial_bytes_, partial_bytes_);
  }
  Partial& p = it->second;
  if (p.seen[no]) return {};  // a copy: taken already
  p.seen[no] = true;
  --p.missing;
  if (no == 0) p.channel.assign(channel);
  std::memcpy(p.payload.data() + offset, body, n);
  if (p.missing == 0) {
    // Done: delivered from a buffer of its own, so that the sink may feed this reader again.
    Partial done = std::move(p);
    partial_.erase(it);
    partial_bytes_ -= done.payload.size();
    sink(done.channel, done.payload.data(), done.payload.size(), utime);
  }
  return {};
}

std::string LcmDatagrams::refuse_new(std::string_view channel, std::uint32_t total, std::int64_t utime) {
  const std::size_t limit = limit_ ? limit_(channel) : std::size_t{kMaxMessageBytes};
  if (limit == 0) return fmt::format("a fragmented message of {} bytes on {}, a channel this node does not read", total, channel);
  if (total > limit) return fmt::format("a fragmented message of {} bytes on {}, whose messages are at most {} bytes", total, channel, limit);
  if (utime > tokens_utime_) {
    tokens_ = std::min(kNewBurst, tokens_ + static_cast<double>(utime - tokens_utime_) * 1e-6 * kNewPerSecond);
    tokens_utime_ = utime;
  }
  if (tokens_ < 1.0) return fmt::format("more than {} new fragmented messages a second: refused", kNewPerSecond);
  tokens_ -= 1.0;
  return {};
}

UdpmReceiver::UdpmReceiver(const UdpmUrl& url, ChannelLimit limit, std::size_t budget)
    : buffer_(kMaxDatagram), datagrams_(std::move(limit), budget) {
  const auto fail = [&](const char* step) {
    const int err = errno;
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    return LcmError(fmt::format("LCM receive socket for {}:{}: {} failed: {}. If this is a multicast problem, fix (as root): {}",
                                url.group, url.port, step, std::strerror(err), kMulticastFixCommand));
  };
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw fail("socket");
  const int one = 1;
  if (::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0) throw fail("SO_REUSEADDR");
  if (url.recv_buf_size > 0) {
    // As liblcm: ask, and take what the kernel grants (net.core.rmem_max caps it).
    (void)::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &url.recv_buf_size, sizeof url.recv_buf_size);
  }
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  addr.sin_port = htons(static_cast<std::uint16_t>(url.port));
  if (::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one) != 0) throw fail("SO_TIMESTAMPNS");
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) throw fail("bind");
  ip_mreq group{};
  group.imr_multiaddr = url.group_addr;
  group.imr_interface.s_addr = htonl(INADDR_ANY);
  if (::setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &group, sizeof group) != 0) throw fail("joining the multicast group");
}

UdpmReceiver::~UdpmReceiver() {
  if (fd_ >= 0) ::close(fd_);
}

std::size_t UdpmReceiver::drain(const MessageSink& sink, std::size_t max_datagrams) {
  std::size_t read = 0;
  while (read < max_datagrams) {
    sockaddr_in from{};
    iovec iov{buffer_.data(), buffer_.size()};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
    msghdr msg{};
    msg.msg_name = &from;
    msg.msg_namelen = sizeof from;
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(fd_, &msg, 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      break;  // EAGAIN: nothing more waiting
    }
    ++read;
    std::int64_t utime = -1;
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
        timespec ts{};
        std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
        utime = std::int64_t{ts.tv_sec} * 1'000'000 + ts.tv_nsec / 1000;
      }
    }
    if (utime < 0) {
      timespec ts{};
      ::clock_gettime(CLOCK_REALTIME, &ts);
      utime = std::int64_t{ts.tv_sec} * 1'000'000 + ts.tv_nsec / 1000;
    }
    const std::uint64_t sender = (std::uint64_t{ntohl(from.sin_addr.s_addr)} << 16) | ntohs(from.sin_port);
    std::string why = datagrams_.feed(buffer_.data(), static_cast<std::size_t>(n), sender, utime, sink);
    if (!why.empty()) {
      ++refused_;
      char host[INET_ADDRSTRLEN] = "?";
      (void)inet_ntop(AF_INET, &from.sin_addr, host, sizeof host);
      last_refusal_ = fmt::format("a datagram of {} bytes from {}:{}: {}", n, host, ntohs(from.sin_port), why);
    }
  }
  return read;
}

}  // namespace hpr::node
