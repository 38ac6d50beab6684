// Bytes: the buffer type of every frame.
//
// A plain std::vector: an allocator that skips zero-filling looks cheaper,
// but libstdc++ then grows and inserts byte by byte instead of with memmove,
// which measured several times slower (bench_protocol).
#pragma once

#include <cstdint>
#include <vector>

namespace holofuse::protocol {

using Bytes = std::vector<uint8_t>;

}  // namespace holofuse::protocol
