// WireWriter and WireReader: the one cursor through which every field of
// protocol/SPEC.md is written and read, little-endian, byte by byte, and
// every other binary format the project reads as well (the half-float mesh
// codec, Draco's header, COLMAP's binary model).
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
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
  // Unsigned integers of T's width, each little-endian, written at once
  // (a mesh's indices): on a little-endian host one copy.
  template <typename T>
  void array(std::span<const T> values) {
    static_assert(std::is_unsigned_v<T>);
    const size_t at = out_.size();
    out_.resize(at + values.size_bytes());
    if constexpr (std::endian::native == std::endian::little) {
      if (!values.empty()) std::memcpy(out_.data() + at, values.data(), values.size_bytes());
    } else {
      for (size_t i = 0; i < values.size(); ++i)
        for (size_t b = 0; b < sizeof(T); ++b)
          out_[at + i * sizeof(T) + b] = static_cast<uint8_t>(values[i] >> (8 * b));
    }
  }

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
  // out.size() unsigned integers of T's width, each little-endian, read
  // with one bounds check (a mesh's indices); zeros once reading failed.
  template <typename T>
  void array(const char* field, std::span<T> out) {
    static_assert(std::is_unsigned_v<T>);
    if (!need(field, out.size_bytes())) {
      std::fill(out.begin(), out.end(), T{0});
      return;
    }
    const uint8_t* at = data_.data() + pos_;
    if constexpr (std::endian::native == std::endian::little) {
      if (!out.empty()) std::memcpy(out.data(), at, out.size_bytes());
    } else {
      for (size_t i = 0; i < out.size(); ++i) {
        T v = 0;
        for (size_t b = sizeof(T); b-- > 0;) v = static_cast<T>((v << 8) | at[i * sizeof(T) + b]);
        out[i] = v;
      }
    }
    pos_ += out.size_bytes();
  }
  // Unsigned LEB128 of at most 5 bytes, above 2^32 - 1 refused (Draco's
  // varUI32).
  uint32_t varint32(const char* field);
  // Bytes up to a NUL, which is read and left out (COLMAP's names).
  std::string cstr(const char* field);
  // Passes over count elements of element_size bytes each, refusing a
  // count the rest cannot hold (no overflow in count * element_size).
  void skip(const char* field, uint64_t count, uint64_t element_size);

  // Records a range error for a value already read (e.g. a count above its cap).
  void failValue(const char* field, StatusCode code, const std::string& detail);

  bool ok() const { return status_.isOk(); }
  const Status& status() const { return status_; }
  // The field the first failure was in and its offset (base_offset
  // added), for formats that word their own errors.
  const std::string& failedField() const { return failed_field_; }
  size_t failedOffset() const { return failed_offset_; }
  size_t offset() const { return pos_; }
  size_t remaining() const { return data_.size() - pos_; }

 private:
  bool need(const char* field, size_t n);
  uint64_t getLe(const char* field, int n);
  void fail(const char* field, StatusCode code, const std::string& detail);

  std::span<const uint8_t> data_;
  size_t pos_ = 0;
  size_t base_offset_ = 0;
  Status status_;
  std::string failed_field_;
  size_t failed_offset_ = 0;
};

constexpr size_t kMaxString = 4096;

}  // namespace holofuse::protocol
