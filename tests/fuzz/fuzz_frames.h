// Frames around fuzzed payloads, as the stream decoder would hand them on
// (the message decoders read the header's type and minor, not its length
// or CRC, which the stream decoder has already checked).
#pragma once

#include <span>

#include "protocol/frame.h"
#include "protocol/messages.h"

namespace holofuse::fuzz {

inline protocol::Frame frameAround(protocol::MessageType type, uint8_t minor,
                                   std::span<const uint8_t> payload) {
  protocol::Frame frame;
  frame.header.type = static_cast<uint16_t>(type);
  frame.header.minor = minor;
  frame.header.payload_length = static_cast<uint32_t>(payload.size());
  frame.bytes.assign(protocol::kHeaderSize, 0);
  frame.bytes.insert(frame.bytes.end(), payload.begin(), payload.end());
  return frame;
}

// The minor a fuzzed input's first byte chooses, among those this build
// speaks.
inline uint8_t minorOf(uint8_t first) {
  return static_cast<uint8_t>(first % (protocol::kVersionMinor + 1));
}

}  // namespace holofuse::fuzz
