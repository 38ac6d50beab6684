#include "protocol/wire.h"

#include <algorithm>
#include <bit>
#include <cstring>

namespace holofuse::protocol {

void WireWriter::f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
void WireWriter::f64(double v) { u64(std::bit_cast<uint64_t>(v)); }

void WireWriter::str(std::string_view s) {
  if (s.size() > kMaxString) s = s.substr(0, kMaxString);
  u16(static_cast<uint16_t>(s.size()));
  raw(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(s.data()), s.size()));
}

void WireWriter::bytes32(std::span<const uint8_t> data) {
  u32(static_cast<uint32_t>(data.size()));
  if (borrow_ != nullptr && data.size() >= kBorrowMinBytes) {
    borrow_->borrow(data);
  } else {
    raw(data);
  }
}

bool WireReader::need(const char* field, size_t n) {
  if (!status_.isOk()) return false;
  if (n <= data_.size() - pos_) return true;
  fail(field, StatusCode::kTruncated,
       "needs " + std::to_string(n) + " bytes, " + std::to_string(data_.size() - pos_) + " left");
  return false;
}

void WireReader::fail(const char* field, StatusCode code, const std::string& detail) {
  failed_field_ = field;
  failed_offset_ = base_offset_ + pos_;
  status_ =
      Status(code, "field '" + failed_field_ + "' at offset " + std::to_string(failed_offset_) +
                       (code == StatusCode::kTruncated ? " " : ": ") + detail);
}

uint64_t WireReader::getLe(const char* field, int n) {
  if (!need(field, static_cast<size_t>(n))) return 0;
  uint64_t v = 0;
  for (int i = n - 1; i >= 0; --i) v = (v << 8) | data_[pos_ + i];
  pos_ += n;
  return v;
}

uint8_t WireReader::u8(const char* field) { return static_cast<uint8_t>(getLe(field, 1)); }
uint16_t WireReader::u16(const char* field) { return static_cast<uint16_t>(getLe(field, 2)); }
uint32_t WireReader::u32(const char* field) { return static_cast<uint32_t>(getLe(field, 4)); }
uint64_t WireReader::u64(const char* field) { return getLe(field, 8); }
float WireReader::f32(const char* field) { return std::bit_cast<float>(u32(field)); }
double WireReader::f64(const char* field) { return std::bit_cast<double>(u64(field)); }

std::string WireReader::str(const char* field) {
  const uint16_t n = u16(field);
  if (n > kMaxString) {
    failValue(field, StatusCode::kTooLarge,
              "string length " + std::to_string(n) + " above cap " + std::to_string(kMaxString));
    return {};
  }
  auto bytes = raw(field, n);
  return std::string(bytes.begin(), bytes.end());
}

std::span<const uint8_t> WireReader::bytes32(const char* field, uint32_t cap) {
  const size_t length_offset = pos_;
  const uint32_t n = u32(field);
  if (ok() && n > cap) {
    pos_ = length_offset;
    failValue(field, StatusCode::kTooLarge,
              "length " + std::to_string(n) + " above cap " + std::to_string(cap));
    return {};
  }
  return raw(field, n);
}

std::span<const uint8_t> WireReader::raw(const char* field, size_t n) {
  if (!need(field, n)) return {};
  auto view = data_.subspan(pos_, n);
  pos_ += n;
  return view;
}

uint32_t WireReader::varint32(const char* field) {
  const size_t start = pos_;
  uint64_t value = 0;
  for (int shift = 0; shift < 35; shift += 7) {
    const uint8_t b = u8(field);
    if (!ok()) return 0;
    value |= uint64_t{b & 0x7Fu} << shift;
    if ((b & 0x80) == 0) {
      if (value <= UINT32_MAX) return static_cast<uint32_t>(value);
      break;
    }
  }
  pos_ = start;
  failValue(field, StatusCode::kMalformed, "not a 32-bit LEB128 number");
  return 0;
}

std::string WireReader::cstr(const char* field) {
  if (!ok()) return {};
  const auto rest = data_.subspan(pos_);
  const auto end = std::find(rest.begin(), rest.end(), uint8_t{0});
  if (end == rest.end()) {
    fail(field, StatusCode::kTruncated,
         "has no NUL in the " + std::to_string(rest.size()) + " bytes left");
    return {};
  }
  std::string text(rest.begin(), end);
  pos_ += text.size() + 1;
  return text;
}

void WireReader::skip(const char* field, uint64_t count, uint64_t element_size) {
  if (!ok()) return;
  if (element_size != 0 && count > remaining() / element_size) {
    fail(field, StatusCode::kTruncated,
         "needs " + std::to_string(count) + " x " + std::to_string(element_size) + " bytes, " +
             std::to_string(remaining()) + " left");
    return;
  }
  pos_ += static_cast<size_t>(count * element_size);
}

void WireReader::failValue(const char* field, StatusCode code, const std::string& detail) {
  if (!status_.isOk()) return;
  fail(field, code, detail);
}

}  // namespace holofuse::protocol
