#include "protocol/crc32c.h"

#include <array>
#include <cstring>

namespace holofuse::protocol {
namespace {

constexpr uint32_t kPolyReflected = 0x82F63B78u;

// Slicing-by-8 tables, built once at start-up.
struct Tables {
  std::array<std::array<uint32_t, 256>, 8> t{};
  Tables() {
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? (c >> 1) ^ kPolyReflected : c >> 1;
      t[0][i] = c;
    }
    for (uint32_t i = 0; i < 256; ++i) {
      for (int s = 1; s < 8; ++s) t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFF];
    }
  }
};

const Tables& tables() {
  static const Tables kTables;
  return kTables;
}

uint64_t loadLe64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

// Multiplication of two polynomials modulo the CRC polynomial, in the
// reflected bit order the CRC register uses (bit 31 is x^0).
uint32_t multiplyModPoly(uint32_t a, uint32_t b) {
  uint32_t product = 0;
  for (uint32_t bit = 1u << 31; bit != 0; bit >>= 1) {
    if (a & bit) product ^= b;
    b = (b & 1) ? (b >> 1) ^ kPolyReflected : b >> 1;
  }
  return product;
}

// x^(8 n) modulo the polynomial: appending n zero bytes to a message
// multiplies its CRC register by this.
uint32_t zeroBytesOperator(size_t n) {
  uint32_t p = 1u << 31;  // x^0
  for (size_t i = 0; i < 8 * n; ++i) p = (p & 1) ? (p >> 1) ^ kPolyReflected : p >> 1;
  return p;
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define HOLOFUSE_HAVE_SSE42_PATH 1
// The crc32 instruction has a latency of 3 cycles and a throughput of 1, so
// one dependency chain uses a third of it. Large inputs run as three
// independent streams of kStreamBytes each; the register is linear over
// GF(2), so the streams combine as
//   crc(A B C) = crc(A) x^(16 L) + crc0(B) x^(8 L) + crc0(C)
// where crc0 starts from a zero register and L = kStreamBytes.
constexpr size_t kStreamBytes = 2048;

// Multiplying by a fixed operator is linear in the register, so it is four
// table lookups (one per register byte) instead of a 32-step loop.
struct ShiftTable {
  std::array<std::array<uint32_t, 256>, 4> t{};
  explicit ShiftTable(uint32_t op) {
    for (int byte = 0; byte < 4; ++byte) {
      for (uint32_t v = 0; v < 256; ++v) t[byte][v] = multiplyModPoly(op, v << (8 * byte));
    }
  }
  uint32_t apply(uint32_t r) const {
    return t[0][r & 0xFF] ^ t[1][(r >> 8) & 0xFF] ^ t[2][(r >> 16) & 0xFF] ^ t[3][r >> 24];
  }
};

struct StreamShifts {
  ShiftTable one{zeroBytesOperator(kStreamBytes)};
  ShiftTable two{zeroBytesOperator(2 * kStreamBytes)};
};

const StreamShifts& streamShifts() {
  static const StreamShifts kShifts;
  return kShifts;
}

__attribute__((target("sse4.2"))) uint32_t crc32cHardware(uint32_t crc, const uint8_t* data,
                                                          size_t size) {
  uint64_t c = ~crc;
  while (size > 0 && (reinterpret_cast<uintptr_t>(data) & 7) != 0) {
    c = __builtin_ia32_crc32qi(static_cast<uint32_t>(c), *data++);
    --size;
  }
  if (size >= 3 * kStreamBytes) {
    const StreamShifts& shifts = streamShifts();
    while (size >= 3 * kStreamBytes) {
      uint64_t b = 0, d = 0;
      const uint8_t* pa = data;
      const uint8_t* pb = data + kStreamBytes;
      const uint8_t* pc = data + 2 * kStreamBytes;
      for (size_t i = 0; i < kStreamBytes; i += 8) {
        uint64_t wa, wb, wc;
        std::memcpy(&wa, pa + i, 8);
        std::memcpy(&wb, pb + i, 8);
        std::memcpy(&wc, pc + i, 8);
        c = __builtin_ia32_crc32di(c, wa);
        b = __builtin_ia32_crc32di(b, wb);
        d = __builtin_ia32_crc32di(d, wc);
      }
      c = shifts.two.apply(static_cast<uint32_t>(c)) ^ shifts.one.apply(static_cast<uint32_t>(b)) ^
          static_cast<uint32_t>(d);
      data += 3 * kStreamBytes;
      size -= 3 * kStreamBytes;
    }
  }
  while (size >= 8) {
    uint64_t word;
    std::memcpy(&word, data, 8);
    c = __builtin_ia32_crc32di(c, word);
    data += 8;
    size -= 8;
  }
  while (size > 0) {
    c = __builtin_ia32_crc32qi(static_cast<uint32_t>(c), *data++);
    --size;
  }
  return ~static_cast<uint32_t>(c);
}

bool cpuHasSse42() {
  static const bool kHas = __builtin_cpu_supports("sse4.2");
  return kHas;
}
#endif

}  // namespace

uint32_t crc32cPortable(uint32_t crc, const uint8_t* data, size_t size) {
  const auto& t = tables().t;
  uint32_t c = ~crc;
  while (size >= 8) {
    uint64_t word = loadLe64(data) ^ c;
    c = t[7][word & 0xFF] ^ t[6][(word >> 8) & 0xFF] ^ t[5][(word >> 16) & 0xFF] ^
        t[4][(word >> 24) & 0xFF] ^ t[3][(word >> 32) & 0xFF] ^ t[2][(word >> 40) & 0xFF] ^
        t[1][(word >> 48) & 0xFF] ^ t[0][word >> 56];
    data += 8;
    size -= 8;
  }
  while (size-- > 0) c = (c >> 8) ^ t[0][(c ^ *data++) & 0xFF];
  return ~c;
}

uint32_t crc32c(uint32_t crc, const uint8_t* data, size_t size) {
#ifdef HOLOFUSE_HAVE_SSE42_PATH
  if (cpuHasSse42()) return crc32cHardware(crc, data, size);
#endif
  return crc32cPortable(crc, data, size);
}

}  // namespace holofuse::protocol
