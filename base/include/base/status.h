// Status and StatusOr: how code that handles outside data (bytes off the
// network, files, flags) reports failure, as a value. The bottom of the
// layers: everything may use it, it uses nothing of the project.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <utility>

namespace holofuse {

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
  kUnauthenticated = 12,  // no key, a wrong key, or a replayed answer
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
  // The value; asking for it when there is none is a broken contract,
  // which aborts with the status rather than read an empty optional.
  T& value() {
    checkHasValue();
    return *value_;
  }
  const T& value() const {
    checkHasValue();
    return *value_;
  }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() { return value(); }
  const T& operator*() const { return value(); }

 private:
  void checkHasValue() const {
    if (value_.has_value()) return;
    std::fprintf(stderr, "StatusOr: value() of an error: %s\n", status_.toString().c_str());
    std::abort();
  }

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

// lhs = the value of expr, or return its status from the function.
#define HOLOFUSE_ASSIGN_OR_RETURN(lhs, expr) \
  HOLOFUSE_ASSIGN_OR_RETURN_IMPL(HOLOFUSE_STATUS_CONCAT(holofuse_or_, __LINE__), lhs, expr)
#define HOLOFUSE_STATUS_CONCAT_INNER(a, b) a##b
#define HOLOFUSE_STATUS_CONCAT(a, b) HOLOFUSE_STATUS_CONCAT_INNER(a, b)
#define HOLOFUSE_ASSIGN_OR_RETURN_IMPL(or_value, lhs, expr) \
  auto or_value = (expr);                                   \
  if (!or_value.isOk()) return or_value.status();           \
  lhs = std::move(or_value.value())

}  // namespace holofuse
