// LatencyReport collects what the client learns per frame (stage stamps
// from every process, end-to-end latency, bytes per link) and writes
// report.json in the layout docs/report-json.md documents.
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "base/arrival_jitter.h"
#include "base/decimated_series.h"
#include "base/status.h"
#include "metrics/health_over_time.h"
#include "protocol/clock_sync.h"
#include "protocol/messages.h"
#include "protocol/stage_budget.h"

namespace holofuse::report {

// A written frame's quality against the truth (metrics/image_metrics.h's measures).
struct FrameQuality {
  double psnr_db = 0, ssim = 0;
};

struct FrameRecord {
  uint64_t frame_id = 0;
  size_t place = 0;  // frames rendered before it in this run (set by addFrame)
  std::string file;
  double end_to_end_ms = 0;
  // The frame's capture on the server's clock and its write on this
  // host's: end to end is taken again with the final clock estimate
  // (settleEndToEnd).
  uint64_t capture_time_ns = 0;
  uint64_t written_local_ns = 0;
  uint32_t cameras_present = 0;
  uint32_t cameras_expected = 0;
  uint64_t pod_bytes = 0;
  uint64_t client_bytes = 0;
  uint64_t feather_bytes = 0;  // of client_bytes, the pods' feather maps (protocol 1.2)
  uint64_t mesh_bytes = 0;     // of client_bytes, the mesh's message
  size_t mesh_triangles = 0;
  std::string note;
  // The written frame against the truth from the same view (a synthetic
  // scene's, ClientOptions::judge): PSNR and SSIM inside the true mask;
  // none when not judged.
  std::optional<FrameQuality> quality;
  // Where this frame's time went: each stage's span on the server's clock
  // (timelineOf), written as ms from its capture; the gaps between spans
  // are waits no stage names (a group held for a client's ask, a mesh
  // waiting for the client's render in hand).
  std::vector<protocol::StageStamp> timeline;
};

// A stamp of the frame's as ms after its capture (negative before it).
double msSinceCapture(const FrameRecord& frame, uint64_t ns);
// One span per stage, in pipeline order: of a stage several pods stamped,
// the one that ended last (the pod the group waited for). Stamps that end
// before they start, or never ended, are left out.
std::vector<protocol::StageStamp> timelineOf(const std::vector<protocol::StageStamp>& stamps);
// A frame's end to end split by its timeline, in ms: one share per stage
// in pipeline order (protocol::stagesInPipelineOrder), then the time no
// stage ran (waiting). A moment two spans cover (the last pod's send and
// the sync wait) goes to the earlier stage, so the shares sum to the end
// to end.
std::vector<double> timeByStage(const FrameRecord& frame);

using protocol::Budget;

// A client may render for days (a soak, a viewer left open), so the report
// holds bounded memory however long it runs: the last kFramesListed frames
// in full and the slowest few apart; every other figure from running
// totals (counts, sums, worst) and from DecimatedSeries (base/), which keep
// an evenly spread sample of each series once it passes 2048 values.
class LatencyReport {
 public:
  static constexpr size_t kFramesListed = 300;
  // Reasons for frames skipped or at start-up: the first ones are named,
  // the rest counted.
  static constexpr size_t kReasonsListed = 100;

  void addStamps(const std::vector<protocol::StageStamp>& stamps);
  void addStage(uint16_t stage, double ms);
  // GPU time of a texture-field pass (timestamp queries), by pass name.
  void addGpuPass(const std::string& name, double ms) { gpu_ms_[name].add(ms); }
  void addFrame(const FrameRecord& record, uint64_t written_ns);
  // Each frame's end to end again, its write moved onto the server's clock
  // by the estimate given (the last, the best of its samples): a frame
  // rendered while the first probes were still answered late (a client
  // busy rendering reads their replies late) was placed by an estimate off
  // by up to half their round trip, tens of ms, even before its capture.
  void settleEndToEnd(const protocol::ClockSync& server_clock);
  // PSNR and SSIM over the frames judged against the truth (FrameRecord);
  // empty when none was.
  struct QualitySummary {
    std::string measure;  // "psnr_db" or "ssim"
    double mean = 0, p50 = 0, worst = 0;
    size_t frames = 0;
  };
  std::vector<QualitySummary> quality() const;
  // The client's time judging a frame (after it is written, before the next).
  void addJudgeMs(double ms) { judge_ms_.add(ms); }
  void noteSkipped(const std::string& why) { skipped_.add(why); }
  // A frame without what this client renders (texture layers) that the
  // server fused before it took the client's request: start-up, until the
  // first frame that has them (startUpEnded). A run in which none came
  // counts them as skipped: the start-up never ended.
  void noteStartUp(const std::string& why) { start_up_.add(why); }
  void startUpEnded() { start_up_ended_ = true; }
  // The reasons named (at most kReasonsListed of each kind), and the counts.
  std::vector<std::string> startUpFrames() const;
  std::vector<std::string> skippedFrames() const;
  uint64_t startUpCount() const { return start_up_ended_ ? start_up_.count : 0; }
  uint64_t skippedCount() const { return skipped_.count + (start_up_ended_ ? 0 : start_up_.count); }
  // Meshes not rendered because a newer one had already arrived.
  void setSuperseded(uint64_t count) { superseded_ = count; }
  // Pictures not written because the writer's queue was full (their frames
  // were rendered and are reported).
  void setPicturesDropped(uint64_t count) { pictures_dropped_ = count; }
  // Camera views of rendered meshes that held none of the subject (left out
  // of every texture-field pass and of the blend).
  void addViewsWithoutSubject(size_t count) { views_without_subject_ += count; }
  // Each pod's mask against the fused hull over the run
  // (render_client/mask_health.h), with the cameras' ids in its order.
  void setMaskHealth(HealthOverTime health, std::vector<uint32_t> camera_ids) {
    mask_health_ = std::move(health);
    mask_health_ids_ = std::move(camera_ids);
  }
  const HealthOverTime& maskHealth() const { return mask_health_; }

  size_t framesRendered() const { return frames_rendered_; }
  double fps() const;
  double endToEndPercentile(double p) const;
  // The last frames rendered, in order: at least the last kFramesListed
  // (all of them in a shorter run), at most twice that.
  const std::vector<FrameRecord>& frames() const { return frames_; }
  // The slowest frames with a timeline (at most kSlowestKept), slowest first.
  static constexpr size_t kSlowestKept = 5;
  std::vector<FrameRecord> slowestFrames() const;
  // The server's account of every pod's frames (Stats since 1.1), the
  // latest received: it covers frames no client rendered too.
  // Since 1.8 they carry each pod's clock against the server's: the
  // first estimate seen per pod is kept to tell drift.
  void setServerArrivals(std::vector<protocol::PodArrivals> arrivals);
  // One host's clock against the server's (protocol/clock_sync.h): pods'
  // as the server measures them, the client's as it measures the server.
  struct HostClock {
    std::string host;  // "client", "pod 3"
    bool measured = false;
    double offset_ms = 0, uncertainty_ms = 0;  // the host's clock minus the server's
    double first_offset_ms = 0, first_uncertainty_ms = 0;
    // Moved further than the threshold from the first estimate, beyond
    // both estimates' uncertainty.
    bool drifted = false;
    double driftMs() const { return offset_ms - first_offset_ms; }
  };
  // The client's own clock against the server's, its first estimate once
  // known, and the drift threshold the report warns at.
  void setClientClock(const HostClock& clock) { client_clock_ = clock; }
  void setClockDriftWarnMs(double ms) { clock_drift_warn_ms_ = ms; }
  std::vector<HostClock> hostClocks() const;
  // One line per drifted clock, naming the host and the move.
  std::vector<std::string> clockWarnings() const;
  // Per pod, its RFC 3550 jitter of PodFrame arrival at the server, ms:
  // the server's over every frame when it sent it, else computed here over
  // the frames behind rendered meshes.
  std::map<uint16_t, double> podJitterMs() const;
  bool jitterFromServer() const { return !server_arrivals_.empty(); }
  // The report as JSON text (latency_report_json.cpp), and as a
  // self-contained HTML page (latency_report_html.cpp: latency budget as
  // stacked bars, GPU passes, bytes per link, per-pod jitter, budget
  // violations flagged).
  std::string toJson(const std::map<std::string, std::string>& settings,
                     const Budget& budget = {}) const;
  std::string toHtml(const std::map<std::string, std::string>& settings,
                     const Budget& budget = {}) const;

 private:
  // The page's table of each budgeted stage against its budget.
  std::string budgetSection(const Budget& budget) const;
  struct Violation {
    std::string stage;
    double p95, budget;
  };
  // Budgeted stages with a sample here are held against their budget at
  // p95; the others are named as not measured.
  std::vector<Violation> violations(const Budget& budget) const;
  std::vector<std::string> unmeasured(const Budget& budget) const;
  bool stageMeasured(const std::string& name) const;
  double stagePercentile(const std::string& name, double p) const;
  using Series = DecimatedSeries<double>;
  std::map<uint16_t, Series> stage_ms_;
  // Per pod, its frames' transit (sent to received, ms) and their RFC 3550
  // jitter, fed in order of arrival: a client learns of them out of order,
  // so the latest kJitterReorder wait in `pending` to be sorted.
  struct PodTransit {
    Series ms;
    std::vector<std::pair<double, double>> pending;  // sent, received
    ArrivalJitter jitter;
    double jitterMs() const;
  };
  static constexpr size_t kJitterReorder = 64;
  std::map<uint16_t, PodTransit> transit_;
  std::vector<protocol::PodArrivals> server_arrivals_;
  // The server's span of the last rendered frame, from its first pod
  // image's decode to its last encode (server clock, ns), and per pair of
  // rendered frames how long the later one's decode ran before the earlier
  // one's encode ended (0: one after the other).
  struct Overlaps {
    Series ms;
    uint64_t overlapped = 0;  // pairs with an overlap
    void add(double v) {
      ms.add(v);
      if (v > 0) ++overlapped;
    }
  };
  std::optional<std::pair<uint64_t, uint64_t>> last_server_span_;
  Overlaps server_overlap_;
  std::optional<uint64_t> last_fusion_end_ns_;  // the last rendered frame's fusion
  Overlaps fusion_overlap_;
  std::map<uint16_t, protocol::PodArrivals> first_pod_clocks_;  // per pod, its first estimate
  std::optional<HostClock> client_clock_;
  double clock_drift_warn_ms_ = 1.0;
  std::map<std::string, Series> gpu_ms_;
  Series judge_ms_;
  // Every frame's end to end, with what settles it again.
  struct FrameTimes {
    uint64_t capture_ns = 0, written_local_ns = 0;
    double end_to_end_ms = 0;
  };
  DecimatedSeries<FrameTimes> end_to_end_;
  std::vector<FrameRecord> frames_;   // the last ones (frames())
  std::vector<FrameRecord> slowest_;  // slowest first
  size_t frames_rendered_ = 0;
  uint64_t first_written_ns_ = 0, last_written_ns_ = 0;
  // Over every frame: bytes per link, frames short of a camera, triangles.
  double pod_bytes_ = 0, client_bytes_ = 0, feather_bytes_ = 0, mesh_bytes_ = 0;
  uint64_t frames_with_missing_cameras_ = 0;
  Series triangles_;
  double most_triangles_ = 0;
  // Judged frames: PSNR and SSIM.
  struct Judged {
    Series values;
    double sum = 0, worst = 0;
    void add(double v) {
      worst = values.empty() ? v : std::min(worst, v);
      values.add(v);
      sum += v;
    }
  };
  Judged psnr_, ssim_;
  struct Reasons {
    std::vector<std::string> named;
    uint64_t count = 0;
    void add(const std::string& why) {
      if (named.size() < kReasonsListed) named.push_back(why);
      ++count;
    }
    std::vector<std::string> listed() const;
  };
  Reasons skipped_, start_up_;
  bool start_up_ended_ = false;
  uint64_t superseded_ = 0;
  uint64_t pictures_dropped_ = 0;
  uint64_t views_without_subject_ = 0;
  HealthOverTime mask_health_;
  std::vector<uint32_t> mask_health_ids_;
};

}  // namespace holofuse::report
