// WireWriter and WireReader: the one cursor through which every field of
// protocol/SPEC.md is written and read, little-endian, byte by byte.
#pragma once

#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "base/status.h"
#include "protocol/bytes.h"

namespace holofuse::protocol {

// Receives bulk ranges a WireWriter does not copy (see OutgoingFrame).
class BorrowSink {
 public:
  virtual ~BorrowSink() = default;
  virtual void borrow(std::span<const uint8_t> data) = 0;
};

class WireWriter {
 public:
  explicit WireWriter(Bytes& out, BorrowSink* borrow = nullptr) : out_(out), borrow_(borrow) {}

  void u8(uint8_t v) { putLe(v, 1); }
  void u16(uint16_t v) { putLe(v, 2); }
  void u32(uint32_t v) { putLe(v, 4); }
  void u64(uint64_t v) { putLe(v, 8); }
  void f32(float v);
  void f64(double v);
  // str: u16 length + bytes. Longer strings are cut at kMaxString.
  void str(std::string_view s);
  // bytes32: u32 length + bytes. With a BorrowSink, large ranges are
  // handed to it instead of copied.
  void bytes32(std::span<const uint8_t> data);
  void raw(std::span<const uint8_t> data) { out_.insert(out_.end(), data.begin(), data.end()); }

  size_t size() const { return out_.size(); }
  Bytes& buffer() { return out_; }

 private:
  void putLe(uint64_t v, int n) {
    uint8_t bytes[8];
    for (int i = 0; i < n; ++i) bytes[i] = static_cast<uint8_t>(v >> (8 * i));
    raw(std::span<const uint8_t>(bytes, static_cast<size_t>(n)));
  }
  Bytes& out_;
  BorrowSink* borrow_;
};

// Bulk ranges at least this large are borrowed rather than copied.
constexpr size_t kBorrowMinBytes = 4096;

// Reads fields from untrusted bytes. Every read names its field; the first
// failure is remembered with the field and its offset and every later read
// fails too, so a decoder can read all fields and check once at the end.
// Safe on any input: bounds are checked as n <= end - pos.
class WireReader {
 public:
  // base_offset is added to offsets in error messages (position of this
  // payload inside the stream or frame).
  explicit WireReader(std::span<const uint8_t> data, size_t base_offset = 0)
      : data_(data), base_offset_(base_offset) {}

  uint8_t u8(const char* field);
  uint16_t u16(const char* field);
  uint32_t u32(const char* field);
  uint64_t u64(const char* field);
  float f32(const char* field);
  double f64(const char* field);
  std::string str(const char* field);
  // A view into the input (no copy); valid as long as the input is.
  std::span<const uint8_t> bytes32(const char* field, uint32_t cap);
  std::span<const uint8_t> raw(const char* field, size_t n);

  // Records a range error for a value already read (e.g. a count above its cap).
  void failValue(const char* field, StatusCode code, const std::string& detail);

  bool ok() const { return status_.isOk(); }
  const Status& status() const { return status_; }
  size_t offset() const { return pos_; }
  size_t remaining() const { return data_.size() - pos_; }

 private:
  bool need(const char* field, size_t n);
  uint64_t getLe(const char* field, int n);

  std::span<const uint8_t> data_;
  size_t pos_ = 0;
  size_t base_offset_ = 0;
  Status status_;
};

constexpr size_t kMaxString = 4096;

}  // namespace holofuse::protocol
