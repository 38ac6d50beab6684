// report.html: the latency report as a self-contained page of tables and
// SVG charts (report/html.h).
#include <algorithm>
#include <cstdio>
#include <optional>

#include "base/statistics.h"
#include "report/html.h"
#include "report/latency_report.h"

namespace holofuse::report {
namespace {

using Rows = std::vector<std::vector<std::string>>;

std::string ms1(double v) { return html::number("%.1f ms", v); }

// The slowest frames' end to end by stage and wait, as stacked bars, each
// frame by its place in the run (its picture is frames/frame_NNNNNN.png).
std::string slowestFramesChart(const std::vector<FrameRecord>& slowest) {
  if (slowest.empty()) return {};
  const std::vector<uint16_t>& order = protocol::stagesInPipelineOrder();
  std::vector<std::vector<double>> shares;
  std::vector<html::StackRow> rows;
  for (const FrameRecord& frame : slowest) {
    shares.push_back(timeByStage(frame));
    rows.push_back({"frame " + std::to_string(frame.place), {}, std::nullopt, ""});
  }
  // Stages no slow frame spent time in are left out of the legend.
  std::vector<std::string> names;
  for (size_t slot = 0; slot <= order.size(); ++slot) {
    bool used = false;
    for (const auto& row : shares) used = used || row[slot] > 0;
    if (!used) continue;
    names.push_back(slot < order.size() ? protocol::stageName(order[slot]) : "waiting");
    for (size_t row = 0; row < rows.size(); ++row) rows[row].segments.push_back(shares[row][slot]);
  }
  return html::stackedBars("The slowest frames: where their time went (waiting: no stage ran)",
                           names, rows, "ms");
}

// Each named series' p50, stacked, with its p50 and p95 in a table: the
// p95s are never stacked (they do not add up); `whole`, where given, marks
// the p95 of the whole on the stack.
using Series = DecimatedSeries<double>;

std::string spreadBars(const std::string& title, const std::vector<std::string>& names,
                       const std::vector<const Series*>& samples,
                       std::optional<double> whole_p95 = std::nullopt,
                       const std::string& whole = "") {
  html::StackRow p50{"p50", {}, whole_p95, whole + " p95"};
  Rows rows;
  for (size_t i = 0; i < samples.size(); ++i) {
    const std::vector<double>& kept = samples[i]->kept();
    p50.segments.push_back(percentile(kept, 50));
    rows.push_back({names[i], ms1(percentile(kept, 50)), ms1(percentile(kept, 95)),
                    std::to_string(samples[i]->count())});
  }
  return html::stackedBars(title, names, {p50}, "ms") +
         html::table({"", "p50", "p95", "samples"}, rows);
}

// The latency budget: the pipeline stages' p50s stacked, the end to end's
// p95 marked.
std::string stageBars(const std::map<uint16_t, Series>& stage_ms, double end_to_end_p95) {
  std::vector<std::string> names;
  std::vector<const Series*> samples;
  for (uint16_t stage : protocol::stagesInPipelineOrder()) {
    const auto it = stage_ms.find(stage);
    if (it == stage_ms.end() || it->second.empty()) continue;
    names.push_back(protocol::stageName(stage));
    samples.push_back(&it->second);
  }
  if (names.empty()) return {};
  return spreadBars("Latency budget: each stage's p50, the end to end's p95 marked", names, samples,
                    end_to_end_p95, "end to end");
}

std::string gpuBars(const std::map<std::string, Series>& gpu_ms) {
  if (gpu_ms.empty()) return {};
  std::vector<std::string> names;
  std::vector<const Series*> samples;
  for (const auto& [name, ms] : gpu_ms) {
    names.push_back(name);
    samples.push_back(&ms);
  }
  return spreadBars("Texture-field passes per new mesh (GPU timestamps, p50)", names, samples);
}

// Every written frame against the scene's true image from the same view,
// inside its true mask (metrics/image_metrics.h's measures).
std::string qualitySection(const std::vector<LatencyReport::QualitySummary>& judged,
                           const Series& judge_ms) {
  if (judged.empty()) return {};
  Rows rows;
  for (const auto& q : judged) {
    const bool db = q.measure == "psnr_db";
    const char* format = db ? "%.2f dB" : "%.4f";
    rows.push_back({db ? "PSNR" : "SSIM", html::number(format, q.mean), html::number(format, q.p50),
                    html::number(format, q.worst), std::to_string(q.frames)});
  }
  return "<h2>Quality against the truth</h2>\n<p>Each written frame against the synthetic "
         "scene's true image from the same view, inside its true mask. Judging took " +
         ms1(percentile(judge_ms.kept(), 50)) +
         " per frame (p50), after the frame was written and before the next.</p>\n" +
         html::table({"measure", "mean", "p50", "worst", "frames"}, rows);
}

// Bytes per link, summed over the run's `frames`.
std::string bytesChart(size_t frames, double pod_bytes, double client_bytes, double feather_bytes) {
  if (frames == 0) return {};
  const double kb = 1000.0 * static_cast<double>(frames);
  return html::barChart(
      "Bytes per frame by link", {"pods -> server", "server -> client", "of which feather maps"},
      {{"KB per frame", {pod_bytes / kb, client_bytes / kb, feather_bytes / kb}}}, "KB");
}

std::string jitterChart(const std::map<uint16_t, double>& jitter, bool from_server) {
  if (jitter.empty()) return {};
  std::vector<std::string> pods;
  html::Series series{"RFC 3550 jitter", {}};
  for (const auto& [pod, ms] : jitter) {
    pods.push_back("pod " + std::to_string(pod));
    series.values.push_back(ms);
  }
  return html::barChart(from_server ? "Arrival jitter per pod (at the server, every frame)"
                                    : "Arrival jitter per pod (frames behind rendered meshes)",
                        pods, {series}, "ms");
}

std::string clocksSection(const std::vector<LatencyReport::HostClock>& clocks, double warn_ms) {
  if (clocks.empty()) return {};
  Rows rows;
  for (const LatencyReport::HostClock& c : clocks) {
    if (!c.measured) {
      rows.push_back({c.host, "not measured (a peer before protocol 1.8)", "", "", ""});
      continue;
    }
    rows.push_back({(c.drifted ? "!" : "") + c.host, html::number("%+.3f ms", c.offset_ms),
                    html::number("%.3f ms", c.uncertainty_ms),
                    html::number("%+.3f ms", c.driftMs()), c.drifted ? "DRIFTED" : "steady"});
  }
  return "<h2>Clocks against the server's</h2>\n<p>Every stamp above is on the server's "
         "clock: each host's times are moved by its offset, estimated from NTP-style probes "
         "(the smallest round trip of the last eight). A clock that moves more than " +
         html::number("%.3f ms", warn_ms) + " beyond the estimates' uncertainty is flagged.</p>\n" +
         html::table({"host", "offset", "uncertainty", "drift", "state"}, rows);
}

std::string maskHealthSection(const HealthOverTime& health,
                              const std::vector<uint32_t>& camera_ids) {
  if (health.frame_ids.empty()) return {};
  Rows rows;
  for (size_t c = 0; c < health.cameras.size(); ++c) {
    const HealthOverTime::Camera& camera = health.cameras[c];
    const std::string id = std::to_string(c < camera_ids.size() ? camera_ids[c] : c);
    rows.push_back({(camera.concern.empty() ? "" : "!") + id, html::number("%.3f", camera.min),
                    html::number("%.3f", camera.median), std::to_string(camera.bad_frames.size()),
                    camera.concern.empty() ? "agrees with the rest" : camera.concern});
  }
  return "<h2>Each pod's mask against the fused hull</h2>\n<p>On " +
         std::to_string(health.frame_ids.size()) +
         " frames, about one a second: each pod's mask IoU with the hull's silhouette in its "
         "camera. A mask under that frame's median by " +
         std::to_string(static_cast<int>(100 * kHealthGap)) +
         " points is set apart (a prop or a light only it sees, or a part of the subject it "
         "misses).</p>\n" +
         html::table({"camera", "IoU min", "IoU median", "frames set apart", "verdict"}, rows);
}

}  // namespace

std::string LatencyReport::budgetSection(const Budget& budget) const {
  if (budget.empty()) return {};
  Rows rows;
  for (const auto& [name, ms] : budget) {
    if (!stageMeasured(name)) {
      rows.push_back({name, ms1(ms), "n/a", "n/a", "not measured: no sample in this run"});
      continue;
    }
    const double p95_ms = stagePercentile(name, 95);
    rows.push_back({(p95_ms > ms ? "!" : "") + name, ms1(ms), ms1(stagePercentile(name, 50)),
                    ms1(p95_ms), p95_ms > ms ? "OVER" : "within"});
  }
  return "<h2>Budget</h2>\n" +
         html::table({"stage", "budget", "p50", "p95", "p95 against budget"}, rows);
}

std::string LatencyReport::toHtml(const std::map<std::string, std::string>& settings,
                                  const Budget& budget) const {
  Rows summary = {{"frames rendered", std::to_string(frames_rendered_)},
                  {"frames per second", html::number("%.1f", fps())},
                  {"end-to-end p50 / p95 / p99", ms1(endToEndPercentile(50)) + " / " +
                                                     ms1(endToEndPercentile(95)) + " / " +
                                                     ms1(endToEndPercentile(99))}};
  // Counts of what did not become a picture, each only where it happened.
  const auto count = [&](const char* what, size_t n) {
    if (n > 0) summary.push_back({what, std::to_string(n)});
  };
  count("meshes superseded (a newer one was waiting)", superseded_);
  count("pictures not written (the writer's queue was full)", pictures_dropped_);
  count("frames at start-up (fused before the server took this client's layers)", startUpCount());
  count("frames skipped (unusable; report.json frames_skipped says why)", skippedCount());
  Rows settings_rows;
  for (const auto& [key, value] : settings) settings_rows.push_back({key, value});
  const std::string body =
      "<h2>Results</h2>\n" + html::table({"", "value"}, summary) +
      stageBars(stage_ms_, endToEndPercentile(95)) + slowestFramesChart(slowest_) +
      gpuBars(gpu_ms_) + qualitySection(quality(), judge_ms_) +
      bytesChart(frames_rendered_, pod_bytes_, client_bytes_, feather_bytes_) +
      jitterChart(podJitterMs(), jitterFromServer()) +
      clocksSection(hostClocks(), clock_drift_warn_ms_) +
      maskHealthSection(mask_health_, mask_health_ids_) + budgetSection(budget) +
      (settings_rows.empty() ? ""
                             : "<h2>Settings</h2>\n" + html::table({"", "value"}, settings_rows));
  return html::page("holofuse live loop report", body);
}

}  // namespace holofuse::report
