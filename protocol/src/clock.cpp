#include "protocol/clock.h"

#include <time.h>

namespace holofuse::protocol {
namespace {
uint64_t read(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000000ull + static_cast<uint64_t>(ts.tv_nsec);
}
}  // namespace

uint64_t monotonicNs() { return read(CLOCK_MONOTONIC); }
uint64_t realtimeNs() { return read(CLOCK_REALTIME); }

}  // namespace holofuse::protocol
