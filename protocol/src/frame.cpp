#include "protocol/frame.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "protocol/crc32c.h"
#include "protocol/wire.h"

namespace holofuse::protocol {

const char* messageTypeName(uint16_t type) {
  switch (static_cast<MessageType>(type)) {
    case MessageType::kHello:
      return "Hello";
    case MessageType::kHelloAck:
      return "HelloAck";
    case MessageType::kAuth:
      return "Auth";
    case MessageType::kCalibration:
      return "Calibration";
    case MessageType::kPodFrame:
      return "PodFrame";
    case MessageType::kMeshFrame:
      return "MeshFrame";
    case MessageType::kTextureBundle:
      return "TextureBundle";
    case MessageType::kHeartbeat:
      return "Heartbeat";
    case MessageType::kStats:
      return "Stats";
    case MessageType::kBye:
      return "Bye";
    case MessageType::kError:
      return "Error";
    case MessageType::kClockProbe:
      return "ClockProbe";
    case MessageType::kFrameRequest:
      return "FrameRequest";
  }
  return "unknown";
}

bool isDroppable(MessageType type) {
  return type == MessageType::kPodFrame || type == MessageType::kMeshFrame ||
         type == MessageType::kTextureBundle;
}

namespace {

void storeCrc(uint8_t* header, uint32_t crc) {
  for (int i = 0; i < 4; ++i) header[kHeaderSize - 4 + i] = static_cast<uint8_t>(crc >> (8 * i));
}

}  // namespace

OutgoingFrame::OutgoingFrame(Bytes contiguous) : own_(std::move(contiguous)) {
  size_ = own_.size();
  parts_.push_back(std::span<const uint8_t>(own_));
}

bool OutgoingFrame::droppable() const {
  return !parts_.empty() && parts_[0].size() >= kHeaderSize && (parts_[0][8] & kFlagDroppable) != 0;
}

Bytes OutgoingFrame::flatten() const {
  Bytes out;
  out.reserve(size_);
  for (const auto& part : parts_) {
    const size_t at = out.size();
    out.resize(at + part.size());
    std::memcpy(out.data() + at, part.data(), part.size());
  }
  return out;
}

FrameBuilder::FrameBuilder(MessageType type, uint64_t sequence, size_t payload_hint)
    : type_(type), sequence_(sequence), writer_(bytes_, this) {
  bytes_.reserve(kHeaderSize + payload_hint);
  bytes_.resize(kHeaderSize);
}

void FrameBuilder::borrowBulk(std::shared_ptr<const void> keep_alive) {
  keep_alive_ = std::move(keep_alive);
}

void FrameBuilder::borrow(std::span<const uint8_t> data) {
  if (keep_alive_ == nullptr) {
    writer_.raw(data);
    return;
  }
  borrowed_.emplace_back(bytes_.size(), data);
}

// Writes header bytes 0..23 to out and returns the CRC over them.
uint32_t FrameBuilder::writeHeader(uint8_t* out, uint32_t payload_length) {
  Bytes header;
  header.reserve(kHeaderSize);
  WireWriter w(header);
  w.raw(kMagic);
  w.u8(kVersionMajor);
  w.u8(minor_);
  w.u16(static_cast<uint16_t>(type_));
  w.u16(isDroppable(type_) ? kFlagDroppable : 0);
  w.u16(0);
  w.u32(payload_length);
  w.u64(sequence_);
  std::memcpy(out, header.data(), kHeaderSize - 4);
  return crc32c(0, out, kHeaderSize - 4);
}

Bytes FrameBuilder::finish() && {
  if (!borrowed_.empty()) return std::move(*this).finishParts().flatten();
  const auto payload_length = static_cast<uint32_t>(bytes_.size() - kHeaderSize);
  uint32_t crc = writeHeader(bytes_.data(), payload_length);
  crc = crc32c(crc, bytes_.data() + kHeaderSize, payload_length);
  storeCrc(bytes_.data(), crc);
  return std::move(bytes_);
}

OutgoingFrame FrameBuilder::finishParts() && {
  size_t borrowed_bytes = 0;
  for (const auto& [at, data] : borrowed_) borrowed_bytes += data.size();
  const auto payload_length = static_cast<uint32_t>(bytes_.size() - kHeaderSize + borrowed_bytes);
  // The own buffer is complete: spans into it stay valid from here on.
  OutgoingFrame frame;
  frame.own_ = std::move(bytes_);
  frame.keep_alive_ = std::move(keep_alive_);
  uint32_t crc = writeHeader(frame.own_.data(), payload_length);
  const uint8_t* own = frame.own_.data();
  size_t own_at = 0;
  auto ownPart = [&](size_t end) {
    if (end > own_at) frame.parts_.emplace_back(own + own_at, end - own_at);
    own_at = end;
  };
  for (const auto& [at, data] : borrowed_) {
    ownPart(at);
    frame.parts_.push_back(data);
  }
  ownPart(frame.own_.size());
  // One CRC pass over everything after the CRC field, in wire order.
  size_t skip = kHeaderSize;
  for (const auto& part : frame.parts_) {
    const size_t drop = std::min(skip, part.size());
    skip -= drop;
    crc = crc32c(crc, part.data() + drop, part.size() - drop);
  }
  storeCrc(frame.own_.data(), crc);
  frame.size_ = kHeaderSize + payload_length;
  return frame;
}

Status parseHeader(std::span<const uint8_t> bytes, uint32_t max_payload, uint64_t stream_offset,
                   FrameHeader& header) {
  WireReader r(bytes.first(std::min(bytes.size(), kHeaderSize)), stream_offset);
  auto magic = r.raw("magic", 4);
  if (r.ok() && !std::equal(magic.begin(), magic.end(), kMagic)) {
    return Status(StatusCode::kBadMagic,
                  "field 'magic' at offset " + std::to_string(stream_offset) + ": expected 'HFUS'");
  }
  header.major = r.u8("major");
  header.minor = r.u8("minor");
  header.type = r.u16("message_type");
  header.flags = r.u16("flags");
  const uint16_t reserved = r.u16("reserved");
  header.payload_length = r.u32("payload_length");
  header.sequence = r.u64("sequence");
  header.crc = r.u32("crc32c");
  HOLOFUSE_RETURN_IF_ERROR(r.status());
  const std::string at = " at offset ";
  if (header.major != kVersionMajor) {
    return Status(StatusCode::kUnsupportedVersion,
                  "field 'major'" + at + std::to_string(stream_offset + 4) + ": version " +
                      std::to_string(header.major) + "." + std::to_string(header.minor) +
                      ", this build speaks " + std::to_string(kVersionMajor) + ".x");
  }
  if ((header.flags & ~kKnownFlags) != 0) {
    return Status(StatusCode::kReservedNonZero,
                  "field 'flags'" + at + std::to_string(stream_offset + 8) + ": reserved bits set");
  }
  if (reserved != 0) {
    return Status(StatusCode::kReservedNonZero,
                  "field 'reserved'" + at + std::to_string(stream_offset + 10) + ": must be 0");
  }
  if (header.payload_length > max_payload) {
    return Status(StatusCode::kTooLarge, "field 'payload_length'" + at +
                                             std::to_string(stream_offset + 12) + ": " +
                                             std::to_string(header.payload_length) +
                                             " bytes above cap " + std::to_string(max_payload));
  }
  return Status::ok();
}

Status verifyCrc(const Frame& frame, uint64_t stream_offset) {
  uint32_t crc = crc32c(0, frame.bytes.data(), kHeaderSize - 4);
  crc = crc32c(crc, frame.bytes.data() + kHeaderSize, frame.bytes.size() - kHeaderSize);
  if (crc != frame.header.crc) {
    return Status(StatusCode::kBadChecksum,
                  "field 'crc32c' at offset " + std::to_string(stream_offset + 24) + ": " +
                      messageTypeName(frame.header.type) + " frame, sequence " +
                      std::to_string(frame.header.sequence) + ", checksum mismatch");
  }
  return Status::ok();
}

std::span<uint8_t> StreamDecoder::writableSpan() {
  if (header_waits_ && !hasFrame()) judgeWaitingHeader();
  if (!status_.isOk() || header_waits_) return {};
  if (!in_payload_)
    return std::span<uint8_t>(header_bytes_ + header_filled_, kHeaderSize - header_filled_);
  return std::span<uint8_t>(current_.bytes).subspan(kHeaderSize + payload_filled_);
}

void StreamDecoder::commit(size_t n) {
  stream_offset_ += n;
  if (!in_payload_) {
    const size_t before = header_filled_;
    header_filled_ += n;
    // Judge the magic as soon as it is in, so a stray protocol (an HTTP
    // probe, say) is refused at once instead of waiting for 28 bytes.
    for (size_t i = before; i < std::min(header_filled_, sizeof(kMagic)); ++i) {
      if (header_bytes_[i] != kMagic[i]) {
        status_ = Status(
            StatusCode::kBadMagic,
            "field 'magic' at offset " + std::to_string(frame_start_offset_) + ": expected 'HFUS'");
        return;
      }
    }
    if (header_filled_ == kHeaderSize) onHeaderComplete(/*may_wait=*/true);
    return;
  }
  payload_filled_ += n;
  if (payload_filled_ == current_.header.payload_length) onFrameComplete();
}

void StreamDecoder::feed(std::span<const uint8_t> data) {
  for (;;) {
    // feed's caller takes frames only after it, so a header is judged as
    // soon as it completes, by the caps in force now.
    if (header_waits_) judgeWaitingHeader();
    if (data.empty() || !status_.isOk()) return;
    auto dst = writableSpan();
    const size_t n = std::min(dst.size(), data.size());
    std::memcpy(dst.data(), data.data(), n);
    data = data.subspan(n);
    commit(n);
  }
}

void StreamDecoder::judgeWaitingHeader() {
  header_waits_ = false;
  onHeaderComplete(/*may_wait=*/false);
}

void StreamDecoder::onHeaderComplete(bool may_wait) {
  FrameHeader header;
  // The type's own cap where it has one: parseHeader checks the length
  // against what this stream allows for it.
  const uint16_t type = static_cast<uint16_t>(header_bytes_[6] | (header_bytes_[7] << 8));
  const uint32_t cap = type < kTypeCaps && type_caps_[type] != 0 ? type_caps_[type] : max_payload_;
  status_ = parseHeader(std::span<const uint8_t>(header_bytes_, kHeaderSize), cap,
                        frame_start_offset_, header);
  if (status_.code() == StatusCode::kTooLarge && may_wait && hasFrame()) {
    status_ = Status::ok();
    header_waits_ = true;
    return;
  }
  if (!status_.isOk()) return;
  // The length passed the cap: only now is the buffer sized.
  current_ = Frame{};
  current_.header = header;
  current_.bytes.resize(kHeaderSize + header.payload_length);
  std::memcpy(current_.bytes.data(), header_bytes_, kHeaderSize);
  payload_filled_ = 0;
  in_payload_ = true;
  if (header.payload_length == 0) onFrameComplete();
}

void StreamDecoder::onFrameComplete() {
  status_ = verifyCrc(current_, frame_start_offset_);
  if (!status_.isOk()) return;
  if (ready_head_ == ready_.size()) {
    ready_.clear();
    ready_head_ = 0;
  }
  ready_.push_back(std::move(current_));
  current_ = Frame{};
  in_payload_ = false;
  header_filled_ = 0;
  frame_start_offset_ = stream_offset_;
}

Frame StreamDecoder::takeFrame() { return std::move(ready_[ready_head_++]); }

size_t StreamDecoder::bufferedBytes() const {
  size_t bytes = in_payload_ ? current_.bytes.capacity() : 0;
  for (size_t i = ready_head_; i < ready_.size(); ++i) bytes += ready_[i].bytes.capacity();
  return bytes;
}

}  // namespace holofuse::protocol
