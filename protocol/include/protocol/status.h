// Status and StatusOr: how code that handles untrusted bytes reports failure.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>

namespace holofuse::protocol {

enum class StatusCode : uint16_t {
  kOk = 0,
  kTruncated = 1,  // more bytes were needed than the input holds
  kBadMagic = 2,
  kUnsupportedVersion = 3,
  kTooLarge = 4,  // a length or count above a cap
  kBadChecksum = 5,
  kMalformed = 6,  // a value out of its allowed range
  kReservedNonZero = 7,
  kUnexpectedMessage = 8,  // a valid message at the wrong moment
  kIoError = 9,
  kClosed = 10,
  kTimeout = 11,
};

const char* statusCodeName(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}
  static Status ok() { return {}; }

  bool isOk() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  // "bad_checksum: crc mismatch at stream offset 1234" style, for logs.
  std::string toString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

template <typename T>
class [[nodiscard]] StatusOr {
 public:
  StatusOr(Status status) : status_(std::move(status)) {}  // NOLINT: implicit by design
  StatusOr(T value) : value_(std::move(value)) {}          // NOLINT: implicit by design

  bool isOk() const { return value_.has_value(); }
  const Status& status() const { return status_; }
  T& value() { return *value_; }
  const T& value() const { return *value_; }
  T* operator->() { return &*value_; }
  T& operator*() { return *value_; }

 private:
  Status status_;
  std::optional<T> value_;
};

#define HOLOFUSE_RETURN_IF_ERROR(expr) \
  do {                                 \
    auto holofuse_status_ = (expr);    \
    if (!holofuse_status_.isOk()) {    \
      return holofuse_status_;         \
    }                                  \
  } while (0)

}  // namespace holofuse::protocol
