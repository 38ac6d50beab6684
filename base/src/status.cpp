#include "base/status.h"

namespace holofuse {

const char* statusCodeName(StatusCode code) {
  switch (code) {
    case StatusCode::kOk:
      return "ok";
    case StatusCode::kTruncated:
      return "truncated";
    case StatusCode::kBadMagic:
      return "bad_magic";
    case StatusCode::kUnsupportedVersion:
      return "unsupported_version";
    case StatusCode::kTooLarge:
      return "too_large";
    case StatusCode::kBadChecksum:
      return "bad_checksum";
    case StatusCode::kMalformed:
      return "malformed";
    case StatusCode::kReservedNonZero:
      return "reserved_non_zero";
    case StatusCode::kUnexpectedMessage:
      return "unexpected_message";
    case StatusCode::kIoError:
      return "io_error";
    case StatusCode::kClosed:
      return "closed";
    case StatusCode::kTimeout:
      return "timeout";
    case StatusCode::kUnauthenticated:
      return "unauthenticated";
  }
  return "unknown";
}

std::string Status::toString() const {
  if (isOk()) return "ok";
  return std::string(statusCodeName(code_)) + ": " + message_;
}

}  // namespace holofuse
