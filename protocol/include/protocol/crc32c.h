// CRC32C (Castagnoli), the frame checksum of protocol/SPEC.md section 2.
#pragma once

#include <cstddef>
#include <cstdint>

namespace holofuse::protocol {

// Continues a CRC: pass 0 to start, the previous result to extend.
// Uses the SSE4.2 instruction when the CPU has it, a table otherwise; both
// give identical results. Safe on any input.
uint32_t crc32c(uint32_t crc, const uint8_t* data, size_t size);

// The table version, exposed so tests can check the fast path against it.
uint32_t crc32cPortable(uint32_t crc, const uint8_t* data, size_t size);

}  // namespace holofuse::protocol
