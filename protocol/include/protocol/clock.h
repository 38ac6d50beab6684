// The one clock of the loop (SPEC.md section 1): CLOCK_MONOTONIC nanoseconds.
#pragma once

#include <cstdint>

namespace holofuse::protocol {

uint64_t monotonicNs();
uint64_t realtimeNs();

}  // namespace holofuse::protocol
