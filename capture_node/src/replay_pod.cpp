#include "capture_node/replay_pod.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <thread>

#include "base/shutdown.h"
#include "capture_node/pod_link.h"
#include "dataset/dataset.h"
#include "protocol/clock.h"
#include "protocol/server_link.h"

namespace holofuse::capture {

using protocol::monotonicNs;

bool parseReplaySpeed(const std::string& text, double& speed) {
  if (text == "max") {
    speed = 0.0;
    return true;
  }
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || !(value > 0.0) || value > 1000.0) return false;
  speed = value;
  return true;
}

namespace {

// The recorded PodFrame with this replay's id, capture time and stamps;
// its planes are borrowed from the recorded bytes, never re-encoded.
StatusOr<protocol::SharedFrame> restamp(const dataset::Dataset& dataset,
                                        const dataset::RecordInfo& record, uint64_t frame_id,
                                        uint32_t camera_id) {
  const uint64_t t0 = monotonicNs();
  auto frame = dataset.readFrame(record);
  if (!frame.isOk()) return frame.status();
  auto owned = std::make_shared<protocol::Frame>(std::move(*frame));
  protocol::PodFrame pod;
  HOLOFUSE_RETURN_IF_ERROR(protocol::decodeFrame(*owned, pod));
  if (pod.camera_id != camera_id) {
    return Status(StatusCode::kMalformed, dataset.records().path() + ": the record at byte " +
                                              std::to_string(record.offset) +
                                              " is filed under camera " +
                                              std::to_string(camera_id) + " but holds camera " +
                                              std::to_string(pod.camera_id));
  }
  pod.frame_id = frame_id;
  pod.capture_time_ns = t0;
  pod.stamps = {{static_cast<uint16_t>(protocol::Stage::kReplayRead),
                 static_cast<uint16_t>(camera_id), t0, monotonicNs()}};
  return std::make_shared<const protocol::OutgoingFrame>(
      protocol::encodeOutgoing(pod, protocol::nextSequence(), std::shared_ptr<const void>(owned)));
}

}  // namespace

int runReplayPod(const ReplayOptions& options) {
  const std::string name = "replay-pod-" + std::to_string(options.pod_id);
  auto dataset = dataset::Dataset::open(options.dataset);
  if (!dataset.isOk()) {
    std::fprintf(stderr, "[%s] %s\n", name.c_str(), dataset.status().message().c_str());
    return 2;
  }
  if (dataset->records().scan().tail_problem) {
    std::fprintf(stderr, "[%s] note: %s; replaying the whole records before it\n", name.c_str(),
                 dataset->records().scan().tail_problem->c_str());
  }
  auto calibration = dataset->readCalibration(options.pod_id);
  if (!calibration.isOk()) {
    std::fprintf(stderr, "[%s] %s\n", name.c_str(), calibration.status().message().c_str());
    return 2;
  }
  const protocol::Calibration calibration_message = *calibration;
  const dataset::DatasetCamera& camera = dataset->cameras().at(options.pod_id);

  PodLink pod_link(options.server, options.pod_id, name, options.key, options.max_minor,
                   calibration_message);
  protocol::ServerLink& link = pod_link.link();
  auto pump = [&](int timeout_ms) { return pod_link.pump(timeout_ms); };

  // Every replay pod derives the same timeline from the same dataset: ids
  // shift by the dataset's id span per loop, times by its duration plus
  // one frame interval.
  const uint64_t id_span = dataset->lastFrameId() - dataset->firstFrameId() + 1;
  const uint64_t duration = dataset->lastTimeNs() - dataset->firstTimeNs();
  const uint64_t interval =
      dataset->frameIds() > 1 ? duration / (dataset->frameIds() - 1) : 100000000ull;
  const uint64_t loop_period = duration + interval;
  const size_t total = camera.frames.size();
  const uint64_t start = monotonicNs();
  uint64_t last_report = start, sent = 0, bytes = 0;
  for (uint64_t loop = 0; !stopRequested(); ++loop) {
    for (size_t i = 0; i < total && !stopRequested(); ++i) {
      const dataset::RecordInfo& record = camera.frames[i];
      // Pace: the recorded receive time (scaled), or the server's accept
      // rate (nothing queued beyond what the socket holds).
      const uint64_t due =
          options.speed > 0
              ? start +
                    static_cast<uint64_t>(static_cast<double>(loop * loop_period + record.time_ns -
                                                              dataset->firstTimeNs()) /
                                          options.speed)
              : 0;
      for (;;) {
        const uint64_t now = monotonicNs();
        const bool ready = link.ready() && link.queuedFrames() == 0 && now >= due;
        if (ready) break;
        const int wait_ms =
            now >= due ? 20 : static_cast<int>(std::min<uint64_t>((due - now) / 1000000 + 1, 50));
        if (!pump(wait_ms)) {
          std::fprintf(stderr, "[%s] giving up: %s\n", name.c_str(),
                       link.fatalError()->toString().c_str());
          return 2;
        }
        if (stopRequested()) break;
      }
      if (stopRequested()) break;
      auto frame = restamp(*dataset, record, record.frame_id + loop * id_span, options.pod_id);
      if (!frame.isOk()) {
        // A damaged record costs that frame, as a dropped frame would.
        std::fprintf(stderr, "[%s] skipping a frame: %s\n", name.c_str(),
                     frame.status().message().c_str());
        continue;
      }
      bytes += (*frame)->size();
      link.send(*frame);
      ++sent;
      pump(0);
      const uint64_t now = monotonicNs();
      if (now - last_report > 2000000000ull) {
        last_report = now;
        const double seconds = static_cast<double>(now - start) / 1e9;
        const double rate = static_cast<double>(sent) / seconds;
        const size_t done = i + 1;
        std::fprintf(stderr, "[%s] loop %llu: %zu/%zu frames, %.1f MB, %.1f frames/s, ETA %.0f s\n",
                     name.c_str(), static_cast<unsigned long long>(loop + 1), done, total,
                     static_cast<double>(bytes) / 1e6, rate,
                     rate > 0 ? static_cast<double>(total - done) / rate : 0.0);
      }
    }
    if (!options.loop || total == 0) break;  // nothing to loop over
  }
  if (total == 0)
    std::fprintf(stderr, "[%s] camera %u has a calibration but no frames\n", name.c_str(),
                 options.pod_id);
  // Everything handed to the socket, then an orderly close that waits for
  // the server to read it all (it may be holding this pod back).
  while (!stopRequested() && link.ready() && link.queuedFrames() > 0) pump(20);
  link.close(stopRequested() ? "replay stopped by signal" : "replay finished",
             stopRequested() ? 500 : 120000);
  std::fprintf(stderr, "[%s] sent %llu frames, %.1f MB\n", name.c_str(),
               static_cast<unsigned long long>(sent), static_cast<double>(bytes) / 1e6);
  return 0;
}

}  // namespace holofuse::capture
