// LatencyReport collects what the client learns per frame (stage stamps
// from every process, end-to-end latency, bytes per link) and writes
// report.json in the layout docs/report-json.md documents.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

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

class LatencyReport {
 public:
  void addStamps(const std::vector<protocol::StageStamp>& stamps);
  void addStage(uint16_t stage, double ms);
  // GPU time of a texture-field pass (timestamp queries), by pass name.
  void addGpuPass(const std::string& name, double ms) { gpu_ms_[name].push_back(ms); }
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
  void addJudgeMs(double ms) { judge_ms_.push_back(ms); }
  void noteSkipped(const std::string& why) { skipped_.push_back(why); }
  // A frame without what this client renders (texture layers) that the
  // server fused before it took the client's request: start-up, until the
  // first frame that has them (startUpEnded). A run in which none came
  // counts them as skipped: the start-up never ended.
  void noteStartUp(const std::string& why) { start_up_.push_back(why); }
  void startUpEnded() { start_up_ended_ = true; }
  std::vector<std::string> startUpFrames() const;
  std::vector<std::string> skippedFrames() const;
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

  size_t framesRendered() const { return frames_.size(); }
  double fps() const;
  double endToEndPercentile(double p) const;
  const std::vector<FrameRecord>& frames() const { return frames_; }
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
  std::map<uint16_t, std::vector<double>> stage_ms_;
  std::map<uint16_t, std::vector<std::pair<double, double>>>
      transit_ms_;  // per pod: sent, received
  std::vector<protocol::PodArrivals> server_arrivals_;
  // The server's span of the last rendered frame, from its first pod
  // image's decode to its last encode (server clock, ns), and per pair of
  // rendered frames how long the later one's decode ran before the earlier
  // one's encode ended (0: one after the other).
  std::optional<std::pair<uint64_t, uint64_t>> last_server_span_;
  std::vector<double> server_overlap_ms_;
  std::optional<uint64_t> last_fusion_end_ns_;  // the last rendered frame's fusion
  std::vector<double> fusion_overlap_ms_;
  std::map<uint16_t, protocol::PodArrivals> first_pod_clocks_;  // per pod, its first estimate
  std::optional<HostClock> client_clock_;
  double clock_drift_warn_ms_ = 1.0;
  std::map<std::string, std::vector<double>> gpu_ms_;
  std::vector<double> judge_ms_;
  std::vector<FrameRecord> frames_;
  std::vector<uint64_t> written_ns_;
  std::vector<std::string> skipped_, start_up_;
  bool start_up_ended_ = false;
  uint64_t superseded_ = 0;
  uint64_t pictures_dropped_ = 0;
  uint64_t views_without_subject_ = 0;
  HealthOverTime mask_health_;
  std::vector<uint32_t> mask_health_ids_;
};

}  // namespace holofuse::report
