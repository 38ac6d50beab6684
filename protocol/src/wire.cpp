#include "protocol/wire.h"

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
  status_ = Status(StatusCode::kTruncated, "field '" + std::string(field) + "' at offset " +
                                               std::to_string(base_offset_ + pos_) + " needs " +
                                               std::to_string(n) + " bytes, " +
                                               std::to_string(data_.size() - pos_) + " left");
  return false;
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

void WireReader::failValue(const char* field, StatusCode code, const std::string& detail) {
  if (!status_.isOk()) return;
  status_ = Status(code, "field '" + std::string(field) + "' at offset " +
                             std::to_string(base_offset_ + pos_) + ": " + detail);
}

}  // namespace holofuse::protocol
