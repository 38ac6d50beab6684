// A sweep point carrying only the numbers the sweep's reports read, for
// the report tests: hull 20 ms (p95 25), the given codecs' and render's ms
// (p95 a quarter more), PSNR and bytes per frame.
#pragma once

#include <string>

#include "eval/sweep.h"

namespace holofuse::eval::test {

inline SweepPoint sweepPoint(const std::string& knob, const std::string& value, bool is_default,
                             const std::string& mode, double psnr, double client_ms,
                             double codec_ms, double bytes) {
  SweepPoint p;
  p.knob = knob;
  p.value = value;
  p.is_default = is_default;
  p.result.name = "clean";
  p.result.hull_ms = 20;
  p.result.hull_ms_p95 = 25;
  p.result.codec_ms = codec_ms;
  p.result.codec_ms_p95 = 1.25 * codec_ms;
  p.result.bytes_per_frame = bytes;
  ModeResult& m = p.result.modes[mode];
  m.psnr_db = psnr;
  m.ms_per_new_mesh = client_ms;
  m.ms_per_new_mesh_p95 = 1.25 * client_ms;
  return p;
}

}  // namespace holofuse::eval::test
