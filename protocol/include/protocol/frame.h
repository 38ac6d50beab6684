// Framing of protocol/SPEC.md section 2: the 28-byte header, building a
// frame in place, and the incremental stream decoder for untrusted input.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "base/status.h"
#include "protocol/bytes.h"
#include "protocol/wire.h"

namespace holofuse::protocol {

constexpr uint8_t kMagic[4] = {'H', 'F', 'U', 'S'};
constexpr uint8_t kVersionMajor = 1;
// 1.1: Stats carries each pod's arrivals; 1.2: a TextureBundle's images
// carry each pod's feather map; 1.3: up to 128 cameras (bundles and Stats'
// arrivals, which 1.2 capped at 64; Stats counts the cameras present); the
// later minors, to 1.13 (a Draco mesh may place its vertices along its keys'
// edges):
// SPEC.md section 3.
constexpr uint8_t kVersionMinor = 13;
constexpr size_t kHeaderSize = 28;
constexpr uint16_t kFlagDroppable = 0x0001;
constexpr uint16_t kKnownFlags = kFlagDroppable;
constexpr uint32_t kDefaultMaxPayload = 64u << 20;

enum class MessageType : uint16_t {
  kHello = 1,
  kHelloAck = 2,
  kAuth = 3,  // since 1.4
  kCalibration = 4,
  kPodFrame = 5,
  kMeshFrame = 6,
  kTextureBundle = 7,
  kHeartbeat = 8,
  kStats = 9,
  kBye = 10,
  kError = 11,
  kClockProbe = 12,    // since 1.8
  kFrameRequest = 13,  // since 1.9
};

const char* messageTypeName(uint16_t type);
// Frame data a slow peer may lose (PodFrame, MeshFrame, TextureBundle).
bool isDroppable(MessageType type);

struct FrameHeader {
  uint8_t major = kVersionMajor;
  uint8_t minor = kVersionMinor;
  uint16_t type = 0;
  uint16_t flags = 0;
  uint32_t payload_length = 0;
  uint64_t sequence = 0;
  uint32_t crc = 0;
};

// A whole frame, header included, in one buffer.
struct Frame {
  FrameHeader header;
  Bytes bytes;
  std::span<const uint8_t> payload() const {
    return std::span<const uint8_t>(bytes).subspan(kHeaderSize);
  }
};

// An encoded frame ready to send: byte ranges that go out back to back, in
// order. Some lie in the frame's own buffer (header, small fields); others
// are borrowed bulk ranges (image planes, Draco bytes) sent in place by
// sendmsg and never copied; keep_alive owns them until the frame is gone.
class OutgoingFrame {
 public:
  OutgoingFrame() = default;
  explicit OutgoingFrame(Bytes contiguous);  // a whole frame in one buffer
  // Parts point into own_: a copy would point into the original.
  OutgoingFrame(const OutgoingFrame&) = delete;
  OutgoingFrame& operator=(const OutgoingFrame&) = delete;
  OutgoingFrame(OutgoingFrame&&) = default;
  OutgoingFrame& operator=(OutgoingFrame&&) = default;

  const std::vector<std::span<const uint8_t>>& parts() const { return parts_; }
  size_t size() const { return size_; }
  bool droppable() const;
  // One contiguous copy (tests, recording).
  Bytes flatten() const;

 private:
  friend class FrameBuilder;
  Bytes own_;
  std::vector<std::span<const uint8_t>> parts_;
  std::shared_ptr<const void> keep_alive_;
  size_t size_ = 0;
};

using SharedFrame = std::shared_ptr<const OutgoingFrame>;

// Builds one frame: the caller writes the payload through writer(), then
// finish() fills in length and CRC. With borrowing on, bulk ranges written
// with bytes32 are referenced instead of copied, and finishParts() returns
// the frame as parts (one CRC pass over everything, no copy of the bulk).
class FrameBuilder : private BorrowSink {
 public:
  FrameBuilder(MessageType type, uint64_t sequence, size_t payload_hint = 0);
  Bytes& buffer() { return bytes_; }
  WireWriter& writer() { return writer_; }
  // Pins the encoded minor (an encoder can speak an older minor).
  void setMinor(uint8_t minor) { minor_ = minor; }
  // From now on bytes32 ranges of kBorrowMinBytes or more are borrowed;
  // keep_alive must own them.
  void borrowBulk(std::shared_ptr<const void> keep_alive);
  Bytes finish() &&;
  OutgoingFrame finishParts() &&;

 private:
  void borrow(std::span<const uint8_t> data) override;
  uint32_t writeHeader(uint8_t* out, uint32_t payload_length);

  MessageType type_;
  uint64_t sequence_;
  uint8_t minor_ = kVersionMinor;
  Bytes bytes_;
  WireWriter writer_;
  // Borrowed ranges and the own-buffer offset each one follows.
  std::vector<std::pair<size_t, std::span<const uint8_t>>> borrowed_;
  std::shared_ptr<const void> keep_alive_;
};

// Parses a header from exactly kHeaderSize bytes and validates everything
// that can be validated without the payload (magic, major, reserved bits,
// length cap). stream_offset is only used in error messages.
Status parseHeader(std::span<const uint8_t> bytes, uint32_t max_payload, uint64_t stream_offset,
                   FrameHeader& header);

// Checks a complete frame's CRC.
Status verifyCrc(const Frame& frame, uint64_t stream_offset);

// Incremental decoder for a byte stream of frames. Feed it bytes in chunks of
// any size; it never allocates more than the header's length after that
// length passed the cap. After an error it stays failed. Safe on untrusted
// input.
class StreamDecoder {
 public:
  explicit StreamDecoder(uint32_t max_payload = kDefaultMaxPayload) : max_payload_(max_payload) {}
  // The cap for frames whose header is still to come (a server raises it
  // once a peer has been admitted).
  void setMaxPayload(uint32_t max_payload) { max_payload_ = max_payload; }
  // A cap of its own for one message type (ids below kTypeCaps), above or
  // below max_payload: a server lets a pod's PodFrames be as large as its
  // calibration allows, and everything else small. 0: max_payload.
  static constexpr size_t kTypeCaps = 16;
  void setTypeCap(uint16_t type, uint32_t cap) {
    if (type < kTypeCaps) type_caps_[type] = cap;
  }

  // Where the next bytes from the socket should go (read straight into the
  // frame's own buffer, so a payload is never copied on receipt). Empty
  // while a header above its cap waits behind frames not yet taken: those
  // frames may raise the cap (a pod's Calibration sizes its PodFrames, and
  // it sends both in one write), so the header is judged by the caps in
  // force once they are taken, and the bytes after it wait in the socket.
  std::span<uint8_t> writableSpan();
  // Accounts for n bytes written into writableSpan().
  void commit(size_t n);
  // Convenience: copies from data through writableSpan/commit until consumed
  // or failed. Its caller takes frames after feeding, so every header is
  // judged as it completes, by the caps in force then.
  void feed(std::span<const uint8_t> data);

  // True when a complete, checked frame can be taken.
  bool hasFrame() const { return ready_head_ < ready_.size(); }
  // Complete frames not yet taken.
  size_t framesWaiting() const { return ready_.size() - ready_head_; }
  // A header waits for the frames before it to be taken (writableSpan).
  bool headerWaits() const { return header_waits_; }
  Frame takeFrame();

  const Status& status() const { return status_; }
  uint64_t bytesConsumed() const { return stream_offset_; }
  // Memory held for frames not yet taken: the one being received (its
  // whole declared payload, allocated once the header passed the cap) and
  // the complete ones waiting.
  size_t bufferedBytes() const;

 private:
  // may_wait: a header above its cap, behind frames not yet taken, waits
  // for them (header_waits_) instead of failing the stream.
  void onHeaderComplete(bool may_wait);
  // Judges the header that waited, by the caps in force now.
  void judgeWaitingHeader();
  void onFrameComplete();

  uint32_t max_payload_;
  std::array<uint32_t, kTypeCaps> type_caps_{};
  Status status_;
  uint8_t header_bytes_[kHeaderSize] = {};
  size_t header_filled_ = 0;
  bool in_payload_ = false;
  bool header_waits_ = false;
  Frame current_;
  size_t payload_filled_ = 0;
  uint64_t stream_offset_ = 0;       // bytes committed so far
  uint64_t frame_start_offset_ = 0;  // stream offset of current frame
  std::vector<Frame> ready_;
  size_t ready_head_ = 0;
};

}  // namespace holofuse::protocol
