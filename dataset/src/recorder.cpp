#include "dataset/recorder.h"

#include <cstdio>
#include <filesystem>
#include <system_error>

#include "protocol/clock.h"

namespace holofuse::dataset {

StatusOr<Recorder> Recorder::open(const std::string& dir, bool record_fused) {
  namespace fs = std::filesystem;
  std::error_code error;
  fs::create_directories(dir, error);
  if (error)
    return Status(StatusCode::kIoError,
                  dir + ": cannot create the recording folder (" + error.message() + ")");
  Recorder recorder;
  recorder.dir_ = dir;
  const uint64_t created = protocol::realtimeNs();
  auto pods = RecordWriter::create((fs::path(dir) / kDatasetPodsFile).string(), created);
  if (!pods.isOk()) return pods.status();
  recorder.pods_ = std::move(*pods);
  if (record_fused) {
    auto fused = RecordWriter::create((fs::path(dir) / kDatasetFusedFile).string(), created);
    if (!fused.isOk()) {
      // Leave no empty pods.hfr behind to block the next attempt.
      (void)recorder.pods_.close();
      fs::remove(fs::path(dir) / kDatasetPodsFile, error);
      return fused.status();
    }
    recorder.fused_ = std::move(*fused);
  }
  recorder.start_ns_ = protocol::monotonicNs();
  recorder.last_report_ns_ = recorder.start_ns_;
  std::fprintf(stderr, "[server] recording pods%s into %s\n",
               record_fused ? " and fused output" : "", dir.c_str());
  return recorder;
}

template <typename Payload>
bool Recorder::append(RecordWriter& writer, RecordKind kind, uint32_t stream, uint64_t frame_id,
                      const Payload& payload) {
  if (writer.failure()) return false;  // already reported
  const uint64_t now = protocol::monotonicNs();
  const Status s = writer.append(kind, stream, frame_id, now - start_ns_, payload);
  if (s.isOk()) return true;
  if (&writer == &pods_) stopped_ns_ = now;
  std::fprintf(stderr, "[server] recording failed, the server goes on: %s\n", s.message().c_str());
  return false;
}

void Recorder::recordPodMessage(RecordKind kind, uint32_t camera_id, uint64_t frame_id,
                                const protocol::Frame& frame) {
  // The frame as received, header and CRC included.
  const bool written =
      append(pods_, kind, camera_id, frame_id, std::span<const uint8_t>(frame.bytes));
  if (kind != RecordKind::kPodFrame) return;
  ++(written ? pod_frames_ : pod_frames_lost_);
}

void Recorder::recordFused(uint64_t frame_id, const protocol::OutgoingFrame& mesh_frame,
                           const protocol::OutgoingFrame& texture_bundle,
                           const protocol::OutgoingFrame& stats) {
  if (!fused_) return;
  append(*fused_, RecordKind::kMeshFrame, kServerStream, frame_id, mesh_frame);
  append(*fused_, RecordKind::kTextureBundle, kServerStream, frame_id, texture_bundle);
  append(*fused_, RecordKind::kStats, kServerStream, frame_id, stats);
}

void Recorder::reportStopped(uint64_t now_ns) const {
  // Stopped: what it holds, when and why, and what has not been kept
  // since, rather than a count that grows as if it still recorded.
  const double mb = static_cast<double>(pods_.bytes()) / 1e6;
  std::fprintf(stderr,
               "[server] recording stopped %.0f s ago (%s): it holds %llu pod frames, %.1f MB; "
               "%llu pod frames not recorded since\n",
               static_cast<double>(now_ns - stopped_ns_) / 1e9, pods_.failure()->message().c_str(),
               static_cast<unsigned long long>(pod_frames_), mb,
               static_cast<unsigned long long>(pod_frames_lost_));
}

void Recorder::maybeReportProgress(uint64_t now_ns, uint64_t interval_ns) {
  if (now_ns - last_report_ns_ < interval_ns) return;
  last_report_ns_ = now_ns;
  const double mb = static_cast<double>(pods_.bytes() + (fused_ ? fused_->bytes() : 0)) / 1e6;
  if (pods_.failure()) {
    reportStopped(now_ns);
    return;
  }
  const double seconds = static_cast<double>(now_ns - start_ns_) / 1e9;
  std::fprintf(stderr, "[server] recording: %llu pod frames, %.1f MB, %.2f MB/s over %.0f s%s\n",
               static_cast<unsigned long long>(pod_frames_), mb, seconds > 0 ? mb / seconds : 0.0,
               seconds, fused_ && fused_->failure() ? " (the fused output has stopped)" : "");
}

void Recorder::close() {
  if (pods_.failure()) reportStopped(protocol::monotonicNs());
  for (RecordWriter* w : {&pods_, fused_ ? &*fused_ : nullptr}) {
    if (w == nullptr || !w->isOpen()) continue;
    const uint64_t records = w->records();
    const Status s = w->close();
    if (s.isOk()) {
      std::fprintf(stderr, "[server] recorded %llu records, %.1f MB, in %s\n",
                   static_cast<unsigned long long>(records), static_cast<double>(w->bytes()) / 1e6,
                   w->path().c_str());
    } else {
      std::fprintf(stderr, "[server] closing %s: %s\n", w->path().c_str(), s.message().c_str());
    }
  }
}

}  // namespace holofuse::dataset
