#include "protocol/handshake.h"

#include <algorithm>
#include <cstdio>

namespace holofuse::protocol {
namespace {

uint32_t packed(uint8_t major, uint8_t minor) { return (uint32_t{major} << 8) | minor; }

std::string range(uint8_t min_major, uint8_t min_minor, uint8_t max_major, uint8_t max_minor) {
  return std::to_string(min_major) + "." + std::to_string(min_minor) + ".." +
         std::to_string(max_major) + "." + std::to_string(max_minor);
}

}  // namespace

StatusOr<HelloAck> negotiate(const Hello& hello, uint8_t max_minor) {
  max_minor = std::min(max_minor, kVersionMinor);
  const uint32_t lo = std::max(packed(hello.min_major, hello.min_minor), packed(kVersionMajor, 0));
  const uint32_t hi =
      std::min(packed(hello.max_major, hello.max_minor), packed(kVersionMajor, max_minor));
  if (lo > hi) {
    return Status(StatusCode::kUnsupportedVersion,
                  "peer speaks " +
                      range(hello.min_major, hello.min_minor, hello.max_major, hello.max_minor) +
                      ", this server speaks " + range(kVersionMajor, 0, kVersionMajor, max_minor));
  }
  HelloAck ack;
  ack.major = static_cast<uint8_t>(hi >> 8);
  ack.minor = static_cast<uint8_t>(hi & 0xFF);
  return ack;
}

Status checkAck(const Hello& offered, const HelloAck& ack) {
  const uint32_t v = packed(ack.major, ack.minor);
  if (v < packed(offered.min_major, offered.min_minor) ||
      v > packed(offered.max_major, offered.max_minor)) {
    return Status(
        StatusCode::kUnsupportedVersion,
        "server picked " + std::to_string(ack.major) + "." + std::to_string(ack.minor) +
            ", outside the offered range " +
            range(offered.min_major, offered.min_minor, offered.max_major, offered.max_minor));
  }
  return Status::ok();
}

StatusOr<uint8_t> parseProtocolVersion(const std::string& text) {
  unsigned major = 0, minor = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%u.%u%c", &major, &minor, &tail) != 2 || major != kVersionMajor ||
      minor > kVersionMinor) {
    return Status(StatusCode::kUnsupportedVersion,
                  "'" + text + "' is not a protocol this build speaks: 1.0 to " +
                      std::to_string(kVersionMajor) + "." + std::to_string(kVersionMinor));
  }
  return static_cast<uint8_t>(minor);
}

}  // namespace holofuse::protocol
