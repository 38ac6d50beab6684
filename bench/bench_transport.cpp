// Loopback transport: N pod connections (4 and 8) each streaming demo-size
// PodFrames to one receiver through the real Connection code; prints the
// throughput and the per-message latency (send start to complete receipt).
#include <poll.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <thread>

#include "capture_node/pod.h"
#include "protocol/clock.h"
#include "protocol/connection.h"
#include "protocol/socket.h"

using namespace holofuse;

namespace {

struct Result {
  double mb_per_s = 0, messages_per_s = 0, p50_us = 0, p95_us = 0;
};

Result run(int pods, const protocol::PodFrame& message, int frames_per_pod) {
  auto listener = protocol::listenTcp({"127.0.0.1", 0});
  const uint16_t port = listener->localPort();
  std::vector<std::unique_ptr<protocol::Connection>> receivers;
  std::vector<std::thread> senders;
  const uint64_t start = protocol::monotonicNs();
  const auto planes_owner = std::make_shared<int>(0);  // the planes live in main for the whole run
  for (int p = 0; p < pods; ++p) {
    senders.emplace_back([&] {
      auto socket = protocol::connectTcp({"127.0.0.1", port}, 1000);
      protocol::ConnectionLimits limits;
      limits.max_queued_droppable = 1000000;
      protocol::Connection c(std::move(*socket), "pod", limits);
      for (int i = 0; i < frames_per_pod; ++i) {
        // The capture time carries the send time for the latency; encoding
        // each frame is part of the cost, as in a pod.
        protocol::PodFrame f = message;
        f.frame_id = static_cast<uint64_t>(i);
        f.capture_time_ns = protocol::monotonicNs();
        c.send(std::make_shared<const protocol::OutgoingFrame>(
            protocol::encodeOutgoing(f, protocol::nextSequence(), planes_owner)));
        while (c.wantsWrite()) {
          (void)c.onWritable();
          if (c.wantsWrite()) {
            pollfd pfd{c.fd(), POLLOUT, 0};
            ::poll(&pfd, 1, 10);
          }
        }
      }
      c.drain(5000);
    });
  }
  std::vector<double> latency_us;
  uint64_t bytes = 0;
  size_t received = 0;
  const size_t expected = static_cast<size_t>(pods) * frames_per_pod;
  while (received < expected) {
    std::vector<pollfd> fds{{listener->fd(), POLLIN, 0}};
    for (auto& r : receivers) fds.push_back({r->fd(), POLLIN, 0});
    ::poll(fds.data(), fds.size(), 100);
    if (fds[0].revents & POLLIN) {
      for (;;) {
        protocol::Socket s = listener->acceptOne(nullptr);
        if (!s.valid()) break;
        receivers.push_back(std::make_unique<protocol::Connection>(std::move(s), "receiver"));
      }
    }
    for (size_t i = 1; i < fds.size(); ++i) {
      if (!(fds[i].revents & POLLIN)) continue;
      (void)receivers[i - 1]->onReadable();
      while (receivers[i - 1]->hasFrame()) {
        const auto frame = receivers[i - 1]->takeFrame();
        protocol::PodFrame f;
        if (!protocol::decodeFrame(frame, f).isOk()) continue;
        latency_us.push_back(static_cast<double>(protocol::monotonicNs() - f.capture_time_ns) /
                             1e3);
        bytes += frame.bytes.size();
        ++received;
      }
    }
  }
  const double seconds = static_cast<double>(protocol::monotonicNs() - start) / 1e9;
  for (auto& t : senders) t.join();
  std::sort(latency_us.begin(), latency_us.end());
  Result r;
  r.mb_per_s = static_cast<double>(bytes) / 1e6 / seconds;
  r.messages_per_s = static_cast<double>(received) / seconds;
  r.p50_us = latency_us[latency_us.size() / 2];
  r.p95_us = latency_us[latency_us.size() * 95 / 100];
  return r;
}

}  // namespace

int main() {
  const scene::SyntheticScene scene;
  const auto cam = scene::SyntheticScene::cameraRig(4, 320, 240)[0];
  capture::PodCapture capture =
      capture::capturePodFrame(scene, cam, scene.backgroundPlate(cam), 10, 0);
  const auto frame =
      capture::encodePodFrame(capture, 0, {protocol::Codec::kLz4PlanarDelta, kFullFrame}).flatten();
  protocol::StreamDecoder decoder;
  decoder.feed(frame);
  const protocol::Frame decoded = decoder.takeFrame();
  protocol::PodFrame message;  // planes point into decoded
  if (!protocol::decodeFrame(decoded, message).isOk()) return 1;
  std::printf("PodFrame at 320x240: %zu bytes on the wire\n", frame.size());
  std::printf("%-6s %12s %12s %14s %14s\n", "pods", "MB/s", "frames/s", "latency p50",
              "latency p95");
  for (int pods : {4, 8}) {
    const Result r = run(pods, message, 400);
    std::printf("%-6d %12.1f %12.0f %11.0f us %11.0f us\n", pods, r.mb_per_s, r.messages_per_s,
                r.p50_us, r.p95_us);
  }
  return 0;
}
