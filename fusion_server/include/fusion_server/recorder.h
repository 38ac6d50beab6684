// The server's recorder: what the pods sent (Calibration and every accepted
// PodFrame, byte for byte as received, with receive times) into
// DIR/pods.hfr, and optionally the fused output (MeshFrame, TextureBundle,
// Stats as sent to clients of the server's own minor) into DIR/fused.hfr. A failed write (a full
// disk) is reported once and stops that file; the server keeps serving.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "fusion_server/fusion_worker.h"
#include "protocol/frame.h"
#include "protocol/record_file.h"

namespace holofuse::fusion {

constexpr const char* kPodsRecordFile = "pods.hfr";
constexpr const char* kFusedRecordFile = "fused.hfr";

class Recorder {
 public:
  // Creates dir if needed; refuses a dir that already holds a recording.
  static StatusOr<Recorder> open(const std::string& dir, bool record_fused);

  void recordPodMessage(protocol::RecordKind kind, uint32_t camera_id, uint64_t frame_id,
                        const protocol::Frame& frame);
  void recordFused(const FusedOutput& output);
  // A progress line (frames, MB, rate) at most every interval_ns.
  void maybeReportProgress(uint64_t now_ns, uint64_t interval_ns = 2000000000ull);
  // Writes the indexes; prints what was recorded.
  void close();

 private:
  template <typename Payload>
  void append(protocol::RecordWriter& writer, protocol::RecordKind kind, uint32_t stream,
              uint64_t frame_id, const Payload& payload);

  std::string dir_;
  protocol::RecordWriter pods_;
  std::optional<protocol::RecordWriter> fused_;
  uint64_t start_ns_ = 0;
  uint64_t last_report_ns_ = 0;
  uint64_t pod_frames_ = 0;
};

}  // namespace holofuse::fusion
