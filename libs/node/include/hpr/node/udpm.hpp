#pragma once
/// \file
/// LCM's UDP multicast transport read without liblcm's receive thread. liblcm (1.3) reads every
/// datagram on a thread of its own and hands it to the caller's thread through a pipe: two
/// wake-ups per message, and on a machine whose idle cores halt (a virtual machine, deep C-states)
/// each wake-up is the larger part of a hop (docs/PERFORMANCE.md, "LCM hop"). A UdpmReceiver is a
/// socket the node's own loop polls and reads: one wake-up, or none when the loop busy-polls.
///
/// The wire format is liblcm's, so that every LCM tool (lcm-spy, lcm-logger, other languages)
/// still talks to the stack: a message is one datagram
///   uint32 magic 0x4c433032 ("LC02"), uint32 sequence number, channel (NUL-terminated), payload
/// or, above 65 499 bytes, fragments of
///   uint32 magic 0x4c433033 ("LC03"), uint32 sequence number, uint32 payload size,
///   uint32 offset of this fragment in the payload, uint16 fragment number, uint16 fragments,
///   then on fragment 0 the channel (NUL-terminated), then the fragment's bytes,
/// every integer big-endian. Publishing stays with liblcm.

#include <netinet/in.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace hpr::node {

/// The parts of a `udpm://GROUP:PORT?...` URL a receiver needs.
struct UdpmUrl {
  std::string group = "239.255.76.67";
  in_addr group_addr{};  ///< `group` as parse_udpm_url read it (network byte order)
  int port = 7667;
  int recv_buf_size = 0;  ///< 0: the system's default
};

/// Whether `url` is a udpm URL.
bool is_udpm_url(const std::string& url);
/// Parses a udpm URL; throws LcmError naming the URL and the part that is wrong.
UdpmUrl parse_udpm_url(const std::string& url);

/// A complete message: its channel, payload (valid during the call only) and receive time [us
/// since the epoch, CLOCK_REALTIME as LCM's log timestamps]: the kernel's time of its (last)
/// datagram's arrival on the host, which on the loopback is the instant it was published.
using MessageSink = std::function<void(std::string_view channel, const std::uint8_t* payload, std::size_t size, std::int64_t utime)>;

/// The largest message [bytes] a node takes on `channel`; 0: the node does not read it.
using ChannelLimit = std::function<std::size_t(std::string_view channel)>;

/// Turns LCM datagrams into messages: short ones at once, fragmented ones once every fragment of a
/// sender's message has arrived (one message in progress per sender, as liblcm: a fragment of a
/// newer message drops the older one). Pure: no socket, so that it is tested and fuzzed alone.
///
/// A fragmented message costs memory only once its first fragment has named a channel the node
/// reads and declared a size within that channel's limit, and only at a bounded rate: a datagram
/// that declares 16 MB for a channel nobody reads, or arrives ahead of its first fragment, is
/// refused without an allocation. (liblcm sends the first fragment first.)
class LcmDatagrams {
 public:
  /// The largest fragmented payload accepted [bytes] (the stack's largest message is a few kB).
  static constexpr std::uint32_t kMaxMessageBytes = 16u << 20;
  /// The most the unfinished messages of all senders may hold together [bytes]: a message that
  /// would exceed it drops every other unfinished one first, so forged fragments from many
  /// senders cannot make a node allocate without bound.
  static constexpr std::size_t kMaxPartialBytes = 32u << 20;
  /// liblcm's limit on a channel name.
  static constexpr std::size_t kMaxChannelLength = 63;
  /// New fragmented messages taken per second, and at once after a quiet time.
  static constexpr double kNewPerSecond = 100.0;
  static constexpr double kNewBurst = 64.0;

  /// `limit`: each channel's largest message (empty: every channel, up to kMaxMessageBytes);
  /// `budget`: the most the unfinished messages may hold together [bytes].
  explicit LcmDatagrams(ChannelLimit limit = {}, std::size_t budget = kMaxPartialBytes)
      : limit_(std::move(limit)), budget_(budget) {}

  /// Feeds one datagram from `sender` (any key unique per sending socket) received at `utime`.
  /// Returns an empty string when the datagram was taken (delivered, or kept as a fragment), else
  /// why it was refused.
  std::string feed(const std::uint8_t* data, std::size_t size, std::uint64_t sender, std::int64_t utime, const MessageSink& sink);
  /// Messages dropped unfinished: a newer message of the same sender began, or the unfinished
  /// messages together would have exceeded kMaxPartialBytes.
  [[nodiscard]] std::int64_t dropped_partial() const { return dropped_partial_; }
  /// Bytes the unfinished messages hold now.
  [[nodiscard]] std::size_t partial_bytes() const { return partial_bytes_; }
  /// The largest the unfinished messages have held together [bytes].
  [[nodiscard]] std::size_t peak_partial_bytes() const { return peak_partial_bytes_; }

 private:
  struct Partial {
    std::uint32_t seqno = 0;
    std::uint32_t size = 0;
    std::uint16_t fragments = 0;
    std::uint16_t missing = 0;
    std::string channel;  ///< empty until fragment 0 arrived
    std::vector<std::uint8_t> payload;
    std::vector<bool> seen;
  };
  std::string feed_fragment(const std::uint8_t* data, std::size_t size, std::uint64_t sender, std::int64_t utime,
                            const MessageSink& sink);
  /// Why the first fragment of a `total`-byte message on `channel` at `utime` starts no message
  /// (empty: it does, and a token of the rate was taken).
  std::string refuse_new(std::string_view channel, std::uint32_t total, std::int64_t utime);
  ChannelLimit limit_;
  std::size_t budget_;
  std::unordered_map<std::uint64_t, Partial> partial_;
  std::int64_t dropped_partial_ = 0;
  std::size_t partial_bytes_ = 0, peak_partial_bytes_ = 0;
  double tokens_ = kNewBurst;
  std::int64_t tokens_utime_ = 0;
};

/// A non-blocking socket joined to a udpm URL's group, bound as liblcm binds (SO_REUSEADDR on the
/// port, so that every process on the host receives every message), with the kernel's receive
/// timestamps (SO_TIMESTAMPNS): a message's time does not depend on when the reader woke.
class UdpmReceiver {
 public:
  /// Throws LcmError when the socket cannot be set up (the message says which step failed).
  /// `limit`: the largest message of each channel the node reads (LcmDatagrams).
  explicit UdpmReceiver(const UdpmUrl& url, ChannelLimit limit = {}, std::size_t budget = LcmDatagrams::kMaxPartialBytes);
  ~UdpmReceiver();
  UdpmReceiver(const UdpmReceiver&) = delete;
  UdpmReceiver& operator=(const UdpmReceiver&) = delete;

  /// The socket: readable when a datagram is waiting.
  [[nodiscard]] int fd() const { return fd_; }
  /// Reads the datagrams waiting (at most `max_datagrams`) and hands each complete message to
  /// `sink`. Returns the number of datagrams read.
  std::size_t drain(const MessageSink& sink, std::size_t max_datagrams = 4096);
  /// Datagrams refused as not LCM's format, and why the latest was.
  [[nodiscard]] std::int64_t refused() const { return refused_; }
  [[nodiscard]] const std::string& last_refusal() const { return last_refusal_; }
  [[nodiscard]] const LcmDatagrams& datagrams() const { return datagrams_; }

 private:
  int fd_ = -1;
  std::vector<std::uint8_t> buffer_;
  LcmDatagrams datagrams_;
  std::int64_t refused_ = 0;
  std::string last_refusal_;
};

}  // namespace hpr::node
