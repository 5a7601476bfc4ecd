#include "hpr/hal/socketcan.hpp"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace hpr::hal {

static_assert(kCanEffFlag == CAN_EFF_FLAG && kCanErrFlag == CAN_ERR_FLAG && kCanRtrFlag == CAN_RTR_FLAG);
static_assert(kCanErrBusOff == CAN_ERR_BUSOFF && kCanErrCrtl == CAN_ERR_CRTL && kCanErrRestarted == CAN_ERR_RESTARTED);

SocketCanTransport::SocketCanTransport(std::string interface, bool fd_frames, const std::vector<SocketCanFilter>& filters)
    : interface_(std::move(interface)), fd_frames_(fd_frames) {
  auto fail = [&](const std::string& what) {
    const std::string why = std::strerror(errno);
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    throw std::runtime_error("socketcan " + interface_ + ": " + what + ": " + why);
  };
  fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) fail("socket(PF_CAN) (does the kernel have CAN support? modprobe can-raw)");
  if (fd_frames_) {
    const int on = 1;
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof(on)) != 0) fail("CAN_RAW_FD_FRAMES");
  }
  const can_err_mask_t err_mask = CAN_ERR_MASK;
  if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask)) != 0) fail("CAN_RAW_ERR_FILTER");
  if (!filters.empty()) {
    std::vector<can_filter> f(filters.size());
    for (std::size_t i = 0; i < filters.size(); ++i) {
      f[i].can_id = filters[i].id;
      f[i].can_mask = filters[i].mask;
    }
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, f.data(), static_cast<socklen_t>(f.size() * sizeof(can_filter))) != 0) {
      fail("CAN_RAW_FILTER");
    }
  }
  const unsigned index = ::if_nametoindex(interface_.c_str());
  if (index == 0) fail("no such interface");
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(index);
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) fail("bind");
}

SocketCanTransport::~SocketCanTransport() {
  if (fd_ >= 0) ::close(fd_);
}

bool SocketCanTransport::send(const CanFrame& frame) {
  ssize_t n = 0;
  if (frame.fd) {
    canfd_frame f{};
    f.can_id = frame.id;
    f.len = fd_length(frame.len);
    f.flags = frame.flags;
    std::memcpy(f.data, frame.data.data(), frame.len);
    n = ::write(fd_, &f, CANFD_MTU);
    if (n == static_cast<ssize_t>(CANFD_MTU)) {
      ++counters_.tx_frames;
      return true;
    }
  } else {
    can_frame f{};
    f.can_id = frame.id;
    f.can_dlc = frame.len > 8 ? 8 : frame.len;
    std::memcpy(f.data, frame.data.data(), f.can_dlc);
    n = ::write(fd_, &f, CAN_MTU);
    if (n == static_cast<ssize_t>(CAN_MTU)) {
      ++counters_.tx_frames;
      return true;
    }
  }
  ++counters_.dropped;
  counters_.last_error = std::string("write: ") + std::strerror(errno);  // ENOBUFS: tx queue full
  return false;
}

int SocketCanTransport::receive(std::vector<CanFrame>& out) {
  int got = 0;
  for (;;) {
    canfd_frame f{};
    const ssize_t n = ::read(fd_, &f, sizeof(f));
    if (n < 0) break;
    if (n != static_cast<ssize_t>(CAN_MTU) && n != static_cast<ssize_t>(CANFD_MTU)) {
      ++counters_.errors;
      continue;
    }
    CanFrame c;
    c.id = f.can_id;
    c.fd = n == static_cast<ssize_t>(CANFD_MTU);
    c.len = f.len;
    c.flags = c.fd ? f.flags : 0;
    std::memcpy(c.data.data(), f.data, c.len > 64 ? 64 : c.len);
    if (account_error_frame(c, counters_)) continue;
    ++counters_.rx_frames;
    out.push_back(c);
    ++got;
  }
  return got;
}

}  // namespace hpr::hal
