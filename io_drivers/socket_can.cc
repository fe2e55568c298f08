#include "io_drivers/socket_can.h"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>

namespace kcrig {

std::int64_t WallClockMicros() {
  timespec now{};
  clock_gettime(CLOCK_REALTIME, &now);
  return static_cast<std::int64_t>(now.tv_sec) * 1000000 + now.tv_nsec / 1000;
}

CanSocket::~CanSocket() { Close(); }

void CanSocket::Close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

Status CanSocket::Open(const CanSocketOptions& options) {
  Close();
  const std::string where = "can:" + options.interface;
  if (options.interface.empty() || options.interface.size() >= IFNAMSIZ) {
    return Status::Error(where + ": not an interface name");
  }
  const int fd =
      ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    return Status::Error(
        where + ": cannot open a CAN socket (" + std::strerror(errno) +
        "; does this kernel have SocketCAN? modprobe can-raw)");
  }
  auto fail = [&](const std::string& what) {
    const int error = errno;
    ::close(fd);
    return Status::Error(where + ": " + what + " (" + std::strerror(error) +
                         ")");
  };
  ifreq request{};
  std::strncpy(request.ifr_name, options.interface.c_str(), IFNAMSIZ - 1);
  if (::ioctl(fd, SIOCGIFINDEX, &request) < 0) {
    return fail("no such CAN interface (ip link add dev " + options.interface +
                " type vcan; ip link set up " + options.interface + ")");
  }
  std::vector<can_filter> filters;
  for (const CanFilter& f : options.filters) {
    filters.push_back({f.id, f.mask | CAN_EFF_FLAG});
  }
  if (!options.filters.empty() &&
      ::setsockopt(
          fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
          static_cast<socklen_t>(filters.size() * sizeof(can_filter))) < 0) {
    return fail("cannot set the receive filters");
  }
  const can_err_mask_t errors = options.error_frames ? CAN_ERR_MASK : 0;
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &errors,
                   sizeof(errors)) < 0) {
    return fail("cannot opt in to error frames");
  }
  const int on = 1;
  if (::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof(on)) < 0) {
    return fail("cannot enable receive time stamps");
  }
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = request.ifr_ifindex;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) < 0) {
    return fail("cannot bind");
  }
  fd_ = fd;
  return Status::Ok();
}

CanSocket::SendResult CanSocket::Send(const CanFrame& frame, int* error) {
  can_frame raw{};
  raw.can_id = frame.extended ? (frame.id & CAN_EFF_MASK) | CAN_EFF_FLAG
                              : frame.id & CAN_SFF_MASK;
  if (frame.remote) raw.can_id |= CAN_RTR_FLAG;
  if (frame.error) raw.can_id = (frame.id & CAN_ERR_MASK) | CAN_ERR_FLAG;
  raw.len = frame.dlc > 8 ? 8 : frame.dlc;
  std::memcpy(raw.data, frame.data, 8);
  const ssize_t sent = ::send(fd_, &raw, sizeof(raw), MSG_DONTWAIT);
  *error = 0;
  if (sent == static_cast<ssize_t>(sizeof(raw))) return SendResult::kSent;
  *error = sent < 0 ? errno : EIO;
  if (*error == ENOBUFS || *error == EAGAIN) return SendResult::kQueueFull;
  return SendResult::kError;
}

bool CanSocket::Receive(TimedCanFrame* timed, int* error) {
  can_frame raw{};
  iovec io{&raw, sizeof(raw)};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timeval))];
  msghdr message{};
  message.msg_iov = &io;
  message.msg_iovlen = 1;
  message.msg_control = control;
  message.msg_controllen = sizeof(control);
  *error = 0;
  const ssize_t n = ::recvmsg(fd_, &message, MSG_DONTWAIT);
  if (n < 0) {
    if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      *error = errno;
    }
    return false;
  }
  if (n != static_cast<ssize_t>(sizeof(raw))) {  // CAN FD: not ours
    *error = EMSGSIZE;
    return false;
  }
  timed->time_us = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr;
       c = CMSG_NXTHDR(&message, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMP) {
      timeval stamp{};
      std::memcpy(&stamp, CMSG_DATA(c), sizeof(stamp));
      timed->time_us =
          static_cast<std::int64_t>(stamp.tv_sec) * 1000000 + stamp.tv_usec;
    }
  }
  if (timed->time_us == 0) timed->time_us = WallClockMicros();
  CanFrame& f = timed->frame;
  f = CanFrame();
  f.error = (raw.can_id & CAN_ERR_FLAG) != 0;
  f.extended = !f.error && (raw.can_id & CAN_EFF_FLAG) != 0;
  f.remote = !f.error && (raw.can_id & CAN_RTR_FLAG) != 0;
  f.id = f.error      ? raw.can_id & CAN_ERR_MASK
         : f.extended ? raw.can_id & CAN_EFF_MASK
                      : raw.can_id & CAN_SFF_MASK;
  f.dlc = raw.len > 8 ? 8 : raw.len;
  std::memcpy(f.data, raw.data, 8);
  return true;
}

bool CanSocket::WaitReadable(double timeout) {
  pollfd p{fd_, POLLIN, 0};
  return ::poll(&p, 1, static_cast<int>(timeout * 1000)) > 0;
}

}  // namespace kcrig
