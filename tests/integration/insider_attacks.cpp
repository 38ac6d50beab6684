#include "insider_attacks.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <deque>

#include "codec/pod_frame_codec.h"
#include "protocol/messages.h"

namespace holofuse::test {

uint64_t floodUntilClosed(int fd, const std::vector<uint8_t>& message, int limit_s) {
  std::vector<uint8_t> burst;
  for (int i = 0; i < 256; ++i) burst.insert(burst.end(), message.begin(), message.end());
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(limit_s);
  uint64_t bytes = 0;
  while (std::chrono::steady_clock::now() < until) {
    const ssize_t n = ::send(fd, burst.data(), burst.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      bytes += static_cast<uint64_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) break;  // closed
    pollfd p{fd, POLLOUT, 0};
    ::poll(&p, 1, 100);
    if (p.revents & (POLLERR | POLLHUP)) break;
  }
  return bytes / message.size();
}

std::vector<uint8_t> frameRequestMessage() {
  return protocol::encodeFrame(protocol::FrameRequest{1, std::nullopt}, 0);
}

std::vector<uint8_t> unknownTypeMessage() {
  protocol::FrameBuilder unknown(static_cast<protocol::MessageType>(99), 0);
  return std::move(unknown).finish();
}

std::vector<uint8_t> clockProbeReplyMessage() {
  return protocol::encodeFrame(protocol::ClockProbe{protocol::ProbeStep::kReply, 1, 2, 3}, 0);
}

protocol::OutgoingFrame wholePodFrame(uint32_t camera, uint64_t frame_id, const Image8& color,
                                      const Image8& mask, const Image8& feather) {
  PodPlanes planes;
  planes.frame_id = frame_id;
  planes.color = &color;
  planes.mask = &mask;
  planes.feather = &feather;
  std::vector<protocol::StageStamp> stamps;
  PodEncoding whole;
  whole.crop_margin = kFullFrame;
  return encodePodFrame(planes, stamps, camera, whole);
}

protocol::SharedFrame emptyPodFrame(uint32_t camera, uint32_t side, uint64_t frame_id) {
  const Image8 color(side, side, 3, 0), mask(side, side, 1, 0), feather(side, side, 1, 0);
  return std::make_shared<const protocol::OutgoingFrame>(
      wholePodFrame(camera, frame_id, color, mask, feather));
}

Trickle::Trickle(uint16_t port, int addresses, size_t hold, std::chrono::milliseconds gap)
    : thread_([=, this](std::stop_token stop) { run(stop, port, addresses, hold, gap); }) {}

void Trickle::run(std::stop_token stop, uint16_t port, int addresses, size_t hold,
                  std::chrono::milliseconds gap) {
  struct Open {
    int fd;
    size_t sent;
    std::chrono::steady_clock::time_point last;
  };
  // The first bytes of a Hello's header: never the whole of it.
  static constexpr uint8_t kHeader[] = {'H', 'F', 'U', 'S', 1, 9, 1, 0, 0, 0, 0, 0,
                                        0,   0,   0,   0,   0, 0, 0, 0, 0, 0, 0};
  std::deque<Open> open;
  for (uint32_t n = 0; !stop.stop_requested(); ++n) {
    const auto now = std::chrono::steady_clock::now();
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    sockaddr_in from{}, to{};
    from.sin_family = to.sin_family = AF_INET;
    from.sin_addr.s_addr = htonl(0x7F000101u + n % static_cast<uint32_t>(addresses));
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    to.sin_port = htons(port);
    if (fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&from), sizeof(from)) == 0 &&
        (::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof(to)) == 0 ||
         errno == EINPROGRESS)) {
      open.push_back({fd, 0, now - std::chrono::seconds(2)});
      ++opened_;
    } else if (fd >= 0) {
      ::close(fd);
    }
    for (Open& o : open) {
      if (o.sent >= sizeof(kHeader) || now - o.last < std::chrono::seconds(1)) continue;
      if (::send(o.fd, &kHeader[o.sent], 1, MSG_NOSIGNAL | MSG_DONTWAIT) == 1) ++o.sent;
      o.last = now;
    }
    while (open.size() > hold) {
      ::close(open.front().fd);
      open.pop_front();
    }
    std::this_thread::sleep_for(gap);
  }
  for (const Open& o : open) ::close(o.fd);
}

}  // namespace holofuse::test
