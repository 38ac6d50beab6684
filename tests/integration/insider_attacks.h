// What keyed insiders and strangers do to a fusion server, for the tests
// that hold SECURITY.md's promises (tests/integration/test_insiders.cpp)
// and the benchmark that measures them (bench/bench_insiders.cpp).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

#include "image/image.h"
#include "protocol/frame.h"

namespace holofuse::test {

// Writes copies of one encoded message to fd as fast as the socket takes
// them, until the server closes the connection or limit_s passes (then the
// flood was never stopped). Returns the copies written.
uint64_t floodUntilClosed(int fd, const std::vector<uint8_t>& message, int limit_s = 60);

// The flood messages an admitted client can send: FrameRequests, a type
// no server knows (99), and clock-probe answers nobody asked for.
std::vector<uint8_t> frameRequestMessage();
std::vector<uint8_t> unknownTypeMessage();
std::vector<uint8_t> clockProbeReplyMessage();

// The PodFrame a pod sends of these whole planes (no crop).
protocol::OutgoingFrame wholePodFrame(uint32_t camera, uint64_t frame_id, const Image8& color,
                                      const Image8& mask, const Image8& feather);

// A PodFrame for camera `camera` whose colour, mask and feather planes are
// side x side and empty: LZ4 makes it a few hundred KB on the wire, 80 MB
// once decompressed at 4096.
protocol::SharedFrame emptyPodFrame(uint32_t camera, uint32_t side, uint64_t frame_id);

// Strangers from many loopback addresses (127.0.1.1, 127.0.1.2, ...), one
// new every `gap` until destroyed, each sending a byte of a header at once
// and one more every second, so it is never silent long enough to be
// closed as idle and never finishes its handshake: a sustained trickle.
// It keeps at most `hold` connections open, closing its oldest.
class Trickle {
 public:
  Trickle(uint16_t port, int addresses, size_t hold, std::chrono::milliseconds gap);
  size_t opened() const { return opened_; }

 private:
  void run(std::stop_token stop, uint16_t port, int addresses, size_t hold,
           std::chrono::milliseconds gap);
  std::atomic<size_t> opened_{0};
  std::jthread thread_;
};

}  // namespace holofuse::test
