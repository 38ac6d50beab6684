// The server's recorder: what the pods sent (Calibration and every accepted
// PodFrame, byte for byte as received, with receive times) into
// DIR/pods.hfr, and optionally the fused output (MeshFrame, TextureBundle,
// Stats as sent to clients of the server's own minor) into DIR/fused.hfr. A failed write (a full
// disk) is reported once and stops that file; the server keeps serving.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "base/status.h"
#include "dataset/dataset.h"
#include "dataset/record_file.h"
#include "protocol/frame.h"

namespace holofuse::dataset {

class Recorder {
 public:
  // Creates dir if needed; refuses a dir that already holds a recording.
  static StatusOr<Recorder> open(const std::string& dir, bool record_fused);

  void recordPodMessage(RecordKind kind, uint32_t camera_id, uint64_t frame_id,
                        const protocol::Frame& frame);
  // One fused frame as the server sent it to clients of its own minor.
  void recordFused(uint64_t frame_id, const protocol::OutgoingFrame& mesh_frame,
                   const protocol::OutgoingFrame& texture_bundle,
                   const protocol::OutgoingFrame& stats);
  // A progress line (frames, MB, rate) at most every interval_ns; once a
  // file has failed, when and why it stopped, what it holds, and how many
  // pod frames were not recorded since.
  void maybeReportProgress(uint64_t now_ns, uint64_t interval_ns = 2000000000ull);
  // Writes the indexes; prints what was recorded.
  void close();

 private:
  void reportStopped(uint64_t now_ns) const;
  // False when nothing was written (this write failed, or one before).
  template <typename Payload>
  bool append(RecordWriter& writer, RecordKind kind, uint32_t stream, uint64_t frame_id,
              const Payload& payload);

  std::string dir_;
  RecordWriter pods_;
  std::optional<RecordWriter> fused_;
  uint64_t start_ns_ = 0;
  uint64_t last_report_ns_ = 0;
  uint64_t pod_frames_ = 0;       // recorded
  uint64_t pod_frames_lost_ = 0;  // accepted after the recording stopped
  uint64_t stopped_ns_ = 0;       // when a write of pods_ failed
};

}  // namespace holofuse::dataset
