#include "render_client/latency_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "base/statistics.h"
#include "common/html_report.h"

namespace holofuse::render {
namespace {

// A stamp of the frame's as ms after its capture (negative before it).
double msSinceCapture(const FrameRecord& frame, uint64_t ns) {
  return static_cast<double>(static_cast<int64_t>(ns - frame.capture_time_ns)) / 1e6;
}

}  // namespace

void LatencyReport::addStamps(const std::vector<protocol::StageStamp>& stamps) {
  using protocol::Stage;
  uint64_t decode_start = UINT64_MAX, fused_end = 0;
  for (const auto& s : stamps) {
    if (s.end_ns < s.start_ns || s.end_ns == 0) continue;
    if (s.stage == static_cast<uint16_t>(Stage::kServerDecode))
      decode_start = std::min(decode_start, s.start_ns);
    for (const Stage after_decode : {Stage::kHull, Stage::kRefine, Stage::kMeshEncode,
                                     Stage::kImageEncode, Stage::kLayers, Stage::kLayerVideo})
      if (s.stage == static_cast<uint16_t>(after_decode)) fused_end = std::max(fused_end, s.end_ns);
  }
  if (decode_start != UINT64_MAX && fused_end >= decode_start) {
    if (last_server_span_) {
      const uint64_t earlier_end = last_server_span_->second;
      server_overlap_ms_.push_back(
          earlier_end > decode_start ? static_cast<double>(earlier_end - decode_start) / 1e6 : 0.0);
    }
    last_server_span_ = {decode_start, fused_end};
  }
  for (const auto& s : stamps) {
    if (s.end_ns >= s.start_ns && s.end_ns != 0)
      addStage(s.stage, static_cast<double>(s.end_ns - s.start_ns) / 1e6);
    // The server stamps each PodFrame's send stage from the pod's encode
    // end (its send time) to its arrival: the transit RFC 3550 watches.
    if (s.stage == static_cast<uint16_t>(protocol::Stage::kSend) && s.end_ns != 0 &&
        s.source < 64) {
      transit_ms_[s.source].emplace_back(static_cast<double>(s.start_ns) / 1e6,
                                         static_cast<double>(s.end_ns) / 1e6);
    }
  }
}

std::vector<protocol::StageStamp> timelineOf(const std::vector<protocol::StageStamp>& stamps) {
  std::map<uint16_t, protocol::StageStamp> latest;
  for (const auto& s : stamps) {
    if (s.end_ns == 0 || s.end_ns < s.start_ns) continue;
    auto [it, added] = latest.try_emplace(s.stage, s);
    if (!added && s.end_ns > it->second.end_ns) it->second = s;
  }
  std::vector<protocol::StageStamp> timeline;
  for (const uint16_t stage : protocol::stagesInPipelineOrder()) {
    if (auto it = latest.find(stage); it != latest.end()) timeline.push_back(it->second);
  }
  return timeline;
}

void LatencyReport::setServerArrivals(std::vector<protocol::PodArrivals> arrivals) {
  for (const auto& a : arrivals) {
    if (a.clock_uncertainty_ns != 0) first_pod_clocks_.emplace(a.pod, a);
  }
  server_arrivals_ = std::move(arrivals);
}

std::vector<LatencyReport::HostClock> LatencyReport::hostClocks() const {
  std::vector<HostClock> clocks;
  if (client_clock_) clocks.push_back(*client_clock_);
  for (const auto& a : server_arrivals_) {
    HostClock clock;
    clock.host = "pod " + std::to_string(a.pod);
    const auto first = first_pod_clocks_.find(a.pod);
    clock.measured = a.clock_uncertainty_ns != 0 && first != first_pod_clocks_.end();
    if (clock.measured) {
      clock.offset_ms = static_cast<double>(a.clock_offset_ns) / 1e6;
      clock.uncertainty_ms = static_cast<double>(a.clock_uncertainty_ns) / 1e6;
      clock.first_offset_ms = static_cast<double>(first->second.clock_offset_ns) / 1e6;
      clock.first_uncertainty_ms = static_cast<double>(first->second.clock_uncertainty_ns) / 1e6;
      clock.drifted = std::abs(clock.driftMs()) >
                      clock_drift_warn_ms_ + clock.uncertainty_ms + clock.first_uncertainty_ms;
    }
    clocks.push_back(clock);
  }
  return clocks;
}

std::vector<std::string> LatencyReport::clockWarnings() const {
  std::vector<std::string> warnings;
  for (const HostClock& c : hostClocks()) {
    if (!c.drifted) continue;
    char text[256];
    std::snprintf(text, sizeof text,
                  "%s's clock moved %+.3f ms against the server's since its first estimate, "
                  "more than %.3f ms beyond the estimates' uncertainty: discipline its host's "
                  "clock (chrony or linuxptp, docs/runbook.md)",
                  c.host.c_str(), c.driftMs(), clock_drift_warn_ms_);
    warnings.push_back(text);
  }
  return warnings;
}

std::vector<LatencyReport::QualitySummary> LatencyReport::quality() const {
  std::vector<double> psnr, ssim;
  for (const auto& f : frames_) {
    if (!f.quality) continue;
    psnr.push_back(f.quality->psnr_db);
    ssim.push_back(f.quality->ssim);
  }
  if (psnr.empty()) return {};
  auto summary = [](const char* name, const std::vector<double>& v) {
    double sum = 0;
    for (double x : v) sum += x;
    return QualitySummary{name, sum / static_cast<double>(v.size()), percentile(v, 50),
                          *std::min_element(v.begin(), v.end()), v.size()};
  };
  return {summary("psnr_db", psnr), summary("ssim", ssim)};
}

std::map<uint16_t, double> LatencyReport::podJitterMs() const {
  std::map<uint16_t, double> jitter;
  for (const auto& a : server_arrivals_) jitter[a.pod] = static_cast<double>(a.jitter_us) / 1000.0;
  if (!jitter.empty()) return jitter;
  for (const auto& [pod, pairs] : transit_ms_) jitter[pod] = interarrivalJitter(pairs);
  return jitter;
}

double LatencyReport::stagePercentile(const std::string& name, double p) const {
  if (name == "end_to_end") return endToEndPercentile(p);
  for (const auto& [stage, v] : stage_ms_) {
    if (protocol::stageName(stage) == name) return percentile(v, p);
  }
  return 0.0;
}

bool LatencyReport::stageMeasured(const std::string& name) const {
  if (name == "end_to_end") return !frames_.empty();
  for (const auto& [stage, v] : stage_ms_) {
    if (protocol::stageName(stage) == name) return !v.empty();
  }
  return false;
}

std::vector<std::string> LatencyReport::unmeasured(const Budget& budget) const {
  std::vector<std::string> names;
  for (const auto& [name, ms] : budget) {
    if (!stageMeasured(name)) names.push_back(name);
  }
  return names;
}

std::vector<LatencyReport::Violation> LatencyReport::violations(const Budget& budget) const {
  std::vector<Violation> over;
  for (const auto& [name, ms] : budget) {
    // A stage that never ran (replay_read in a live run, pod_render in a
    // replay) has no p95 to hold against its budget: it is named, not passed.
    if (!stageMeasured(name)) continue;
    const double p95 = stagePercentile(name, 95);
    if (p95 > ms) over.push_back({name, p95, ms});
  }
  return over;
}

void LatencyReport::addStage(uint16_t stage, double ms) { stage_ms_[stage].push_back(ms); }

void LatencyReport::addFrame(const FrameRecord& record, uint64_t written_ns) {
  frames_.push_back(record);
  written_ns_.push_back(written_ns);
}

void LatencyReport::settleEndToEnd(const protocol::ClockSync& server_clock) {
  for (FrameRecord& f : frames_) {
    if (f.written_local_ns == 0 || f.capture_time_ns == 0) continue;
    const auto written = static_cast<int64_t>(server_clock.toPeer(f.written_local_ns));
    f.end_to_end_ms = static_cast<double>(written - static_cast<int64_t>(f.capture_time_ns)) / 1e6;
  }
}

double LatencyReport::fps() const {
  if (written_ns_.size() < 2) return 0.0;
  const double seconds = static_cast<double>(written_ns_.back() - written_ns_.front()) / 1e9;
  return seconds > 0 ? static_cast<double>(written_ns_.size() - 1) / seconds : 0.0;
}

double LatencyReport::endToEndPercentile(double p) const {
  std::vector<double> e2e;
  for (const auto& f : frames_) e2e.push_back(f.end_to_end_ms);
  return percentile(e2e, p);
}

std::string LatencyReport::toJson(const std::map<std::string, std::string>& settings,
                                  const Budget& budget) const {
  nlohmann::ordered_json j;
  j["frames_rendered"] = frames_.size();
  j["fps"] = fps();
  j["latency_ms"]["end_to_end"] = {{"p50", endToEndPercentile(50)},
                                   {"p95", endToEndPercentile(95)},
                                   {"p99", endToEndPercentile(99)}};
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();
  for (uint16_t stage : protocol::stagesInPipelineOrder()) {
    auto it = stage_ms_.find(stage);
    const std::vector<double> none;
    const auto& v = it == stage_ms_.end() ? none : it->second;
    stages[protocol::stageName(stage)] = {
        {"p50", percentile(v, 50)}, {"p95", percentile(v, 95)}, {"samples", v.size()}};
  }
  for (const auto& [stage, v] : stage_ms_) {
    if (stage < protocol::kFirstStage || stage > protocol::kLastStage) {
      stages[protocol::stageName(stage)] = {
          {"p50", percentile(v, 50)}, {"p95", percentile(v, 95)}, {"samples", v.size()}};
    }
  }
  j["latency_ms"]["stages"] = stages;
  // Texture-field passes on the GPU, once per new mesh (paper 000 Table 3).
  nlohmann::ordered_json gpu = nlohmann::ordered_json::object();
  for (const auto& [name, v] : gpu_ms_) {
    gpu[name] = {{"p50", percentile(v, 50)}, {"p95", percentile(v, 95)}, {"samples", v.size()}};
  }
  j["latency_ms"]["gpu_passes"] = gpu;
  // Per link, one way: each pod's frames to the server (its send stamps
  // behind rendered meshes), and the server's frames to this client (the
  // fan-out, from the server's send to the arrival here).
  nlohmann::ordered_json links = nlohmann::ordered_json::object();
  for (const auto& [pod, pairs] : transit_ms_) {
    std::vector<double> ms;
    for (const auto& [sent, received] : pairs) ms.push_back(received - sent);
    links["pod_" + std::to_string(pod) + "_to_server"] = {
        {"p50", percentile(ms, 50)}, {"p95", percentile(ms, 95)}, {"samples", ms.size()}};
  }
  if (const auto fanout = stage_ms_.find(static_cast<uint16_t>(protocol::Stage::kFanout));
      fanout != stage_ms_.end()) {
    links["server_to_client"] = {{"p50", percentile(fanout->second, 50)},
                                 {"p95", percentile(fanout->second, 95)},
                                 {"samples", fanout->second.size()}};
  }
  j["latency_ms"]["links"] = links;
  // The server's pipeline: how often it decoded a frame's pod images while
  // it was still carving or encoding the frame before.
  size_t overlapped = 0;
  for (const double ms : server_overlap_ms_) overlapped += ms > 0 ? 1 : 0;
  j["server_pipeline"] = {
      {"frame_pairs", server_overlap_ms_.size()},
      {"overlapped", overlapped},
      {"overlap_ms",
       {{"p50", percentile(server_overlap_ms_, 50)}, {"p95", percentile(server_overlap_ms_, 95)}}}};
  double pod_bytes = 0, client_bytes = 0, feather_bytes = 0, mesh_bytes = 0;
  std::vector<double> triangles;
  size_t incomplete = 0;
  for (const auto& f : frames_) {
    pod_bytes += static_cast<double>(f.pod_bytes);
    client_bytes += static_cast<double>(f.client_bytes);
    feather_bytes += static_cast<double>(f.feather_bytes);
    mesh_bytes += static_cast<double>(f.mesh_bytes);
    triangles.push_back(static_cast<double>(f.mesh_triangles));
    if (f.cameras_present < f.cameras_expected) ++incomplete;
  }
  const double n = std::max<double>(1.0, static_cast<double>(frames_.size()));
  j["bytes_per_frame"] = {{"pod_link", pod_bytes / n},
                          {"client_link", client_bytes / n},
                          {"client_link_feather_maps", feather_bytes / n},
                          {"client_link_mesh", mesh_bytes / n}};
  j["mesh_triangles"] = {{"p50", percentile(triangles, 50)}, {"max", percentile(triangles, 100)}};
  j["frames_with_missing_cameras"] = incomplete;
  nlohmann::ordered_json jitter = nlohmann::ordered_json::object();
  for (const auto& [pod, ms] : podJitterMs()) jitter["pod_" + std::to_string(pod)] = ms;
  j["jitter_ms"] = jitter;
  if (jitterFromServer()) {
    j["jitter_source"] = "server, over every pod frame received";
    nlohmann::ordered_json received = nlohmann::ordered_json::object();
    for (const auto& a : server_arrivals_) received["pod_" + std::to_string(a.pod)] = a.frames;
    j["pod_frames_at_server"] = received;
  } else if (!jitter.empty()) {
    j["jitter_source"] =
        "client, over the pod frames behind rendered meshes (the server sent no arrivals)";
  }
  // Every host's clock against the server's, which the stamps are on.
  nlohmann::ordered_json clocks = nlohmann::ordered_json::object();
  for (const HostClock& c : hostClocks()) {
    std::string key = c.host;
    std::replace(key.begin(), key.end(), ' ', '_');
    if (!c.measured) {
      clocks[key] = {{"measured", false}};
      continue;
    }
    clocks[key] = {{"measured", true},
                   {"offset_ms", c.offset_ms},
                   {"uncertainty_ms", c.uncertainty_ms},
                   {"drift_ms", c.driftMs()},
                   {"drifted", c.drifted}};
  }
  j["clocks"] = {{"against", "the server's CLOCK_MONOTONIC, which every stamp is on"},
                 {"drift_warn_ms", clock_drift_warn_ms_},
                 {"hosts", clocks},
                 {"warnings", clockWarnings()}};
  if (!budget.empty()) {
    j["budget_ms"] = budget;
    nlohmann::ordered_json over = nlohmann::ordered_json::array();
    for (const auto& v : violations(budget))
      over.push_back({{"stage", v.stage}, {"p95", v.p95}, {"budget", v.budget}});
    j["budget_violations"] = over;
    j["budget_unmeasured"] = unmeasured(budget);
  }
  // Each judged frame against the truth from its view (--truth-scene).
  nlohmann::ordered_json quality = nlohmann::ordered_json::object();
  for (const auto& q : this->quality()) {
    quality[q.measure] = {
        {"mean", q.mean}, {"p50", q.p50}, {"worst", q.worst}, {"frames", q.frames}};
  }
  if (!judge_ms_.empty()) {
    quality["judge_ms"] = {{"p50", percentile(judge_ms_, 50)}, {"p95", percentile(judge_ms_, 95)}};
  }
  j["quality"] = quality;
  j["frames_skipped"] = skipped_;
  j["frames_superseded"] = superseded_;
  j["pictures_dropped"] = pictures_dropped_;
  j["camera_views_without_subject"] = views_without_subject_;
  // Each pod's mask against the fused hull, sampled about once a second.
  nlohmann::ordered_json health = nlohmann::ordered_json::object();
  health["frames_measured"] = mask_health_.frame_ids;
  health["cameras"] = nlohmann::ordered_json::array();
  for (size_t c = 0; c < mask_health_.cameras.size(); ++c) {
    const HealthOverTime::Camera& camera = mask_health_.cameras[c];
    nlohmann::ordered_json entry;
    entry["camera"] = c < mask_health_ids_.size() ? mask_health_ids_[c] : c;
    entry["iou_min"] = camera.min;
    entry["iou_median"] = camera.median;
    entry["frames_set_apart"] = camera.bad_frames;
    entry["concern"] = camera.concern;
    health["cameras"].push_back(entry);
  }
  j["mask_health"] = health;
  j["settings"] = settings;
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  for (const auto& f : frames_) {
    nlohmann::ordered_json timeline = nlohmann::ordered_json::object();
    for (const auto& s : f.timeline)
      timeline[protocol::stageName(s.stage)] = {msSinceCapture(f, s.start_ns),
                                                msSinceCapture(f, s.end_ns)};
    frames.push_back(
        {{"frame_id", f.frame_id},
         {"file", f.file},
         {"end_to_end_ms", f.end_to_end_ms},
         {"cameras_present", f.cameras_present},
         {"cameras_expected", f.cameras_expected},
         {"pod_bytes", f.pod_bytes},
         {"client_bytes", f.client_bytes},
         {"mesh_bytes", f.mesh_bytes},
         {"mesh_triangles", f.mesh_triangles},
         {"psnr_db",
          f.quality ? nlohmann::ordered_json(f.quality->psnr_db) : nlohmann::ordered_json()},
         {"ssim", f.quality ? nlohmann::ordered_json(f.quality->ssim) : nlohmann::ordered_json()},
         {"note", f.note},
         {"timeline_ms", timeline}});
  }
  j["frames"] = frames;
  return j.dump(2) + "\n";
}

}  // namespace holofuse::render

namespace holofuse::render {

std::vector<double> timeByStage(const FrameRecord& frame) {
  const std::vector<uint16_t>& order = protocol::stagesInPipelineOrder();
  struct Span {
    double from, to;
    size_t slot;  // the stage's place in the pipeline order
  };
  std::vector<Span> spans;
  std::vector<double> edges = {0.0, frame.end_to_end_ms};
  for (const auto& s : frame.timeline) {
    const auto at = std::find(order.begin(), order.end(), s.stage);
    spans.push_back({msSinceCapture(frame, s.start_ns), msSinceCapture(frame, s.end_ns),
                     static_cast<size_t>(at - order.begin())});
    edges.insert(edges.end(), {spans.back().from, spans.back().to});
  }
  std::sort(edges.begin(), edges.end());
  std::vector<double> shares(order.size() + 1);
  for (size_t e = 0; e + 1 < edges.size(); ++e) {
    const double from = std::max(edges[e], 0.0), to = std::min(edges[e + 1], frame.end_to_end_ms);
    if (to <= from) continue;
    size_t slot = order.size();  // no stage ran
    for (const Span& s : spans)
      if (s.from <= from && s.to >= to) slot = std::min(slot, s.slot);
    shares[slot] += to - from;
  }
  return shares;
}

std::string LatencyReport::slowestFrames() const {
  std::vector<const FrameRecord*> slowest;
  for (const auto& f : frames_)
    if (!f.timeline.empty()) slowest.push_back(&f);
  std::sort(slowest.begin(), slowest.end(), [](const FrameRecord* a, const FrameRecord* b) {
    return a->end_to_end_ms > b->end_to_end_ms;
  });
  slowest.resize(std::min<size_t>(slowest.size(), 5));
  if (slowest.empty()) return {};
  const std::vector<uint16_t>& order = protocol::stagesInPipelineOrder();
  std::vector<std::vector<double>> shares;
  std::vector<html::StackRow> rows;
  for (const FrameRecord* f : slowest) {
    shares.push_back(timeByStage(*f));
    char label[64];
    std::snprintf(label, sizeof(label), "frame %llu, %.0f ms",
                  static_cast<unsigned long long>(f->frame_id), f->end_to_end_ms);
    rows.push_back({label, {}});
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

std::string LatencyReport::toHtml(const std::map<std::string, std::string>& settings,
                                  const Budget& budget) const {
  auto format = [](double v, const char* unit) {
    char buffer[48];
    std::snprintf(buffer, sizeof(buffer), "%.1f%s", v, unit);
    return std::string(buffer);
  };
  std::string body;
  std::vector<std::vector<std::string>> summary = {
      {"frames rendered", std::to_string(frames_.size())},
      {"frames per second", format(fps(), "")},
      {"end-to-end p50 / p95 / p99", format(endToEndPercentile(50), " ms") + " / " +
                                         format(endToEndPercentile(95), " ms") + " / " +
                                         format(endToEndPercentile(99), " ms")},
      {"meshes superseded (a newer one was waiting)", std::to_string(superseded_)},
      {"pictures not written (the writer's queue was full)", std::to_string(pictures_dropped_)},
      {"frames skipped (bad input)", std::to_string(skipped_.size())}};
  for (const auto& [key, value] : settings) summary.push_back({key, value});
  body += html::table({"", "value"}, summary);
  // The latency budget: the pipeline stages stacked, at p50 and at p95.
  std::vector<std::string> stages;
  html::StackRow p50{"p50", {}}, p95{"p95", {}};
  for (uint16_t stage : protocol::stagesInPipelineOrder()) {
    const auto it = stage_ms_.find(stage);
    if (it == stage_ms_.end()) continue;
    stages.push_back(protocol::stageName(stage));
    p50.segments.push_back(percentile(it->second, 50));
    p95.segments.push_back(percentile(it->second, 95));
  }
  body += html::stackedBars("Latency budget per stage", stages, {p50, p95}, "ms");
  body += slowestFrames();
  if (!gpu_ms_.empty()) {
    std::vector<std::string> passes;
    html::StackRow gpu50{"p50", {}}, gpu95{"p95", {}};
    for (const auto& [name, v] : gpu_ms_) {
      passes.push_back(name);
      gpu50.segments.push_back(percentile(v, 50));
      gpu95.segments.push_back(percentile(v, 95));
    }
    body += html::stackedBars("Texture-field passes per new mesh (GPU timestamps)", passes,
                              {gpu50, gpu95}, "ms");
  }
  double pod_bytes = 0, client_bytes = 0, feather_bytes = 0;
  for (const auto& f : frames_) {
    pod_bytes += static_cast<double>(f.pod_bytes);
    client_bytes += static_cast<double>(f.client_bytes);
    feather_bytes += static_cast<double>(f.feather_bytes);
  }
  const std::vector<QualitySummary> judged = quality();
  if (!judged.empty()) {
    // The quality table: every written frame against the scene's true image
    // from the same view, inside its true mask (metrics/image_metrics.h's measures).
    std::vector<std::vector<std::string>> rows;
    for (const auto& q : judged) {
      const bool db = q.measure == "psnr_db";
      auto cell = [&](double v) {
        char text[32];
        std::snprintf(text, sizeof(text), db ? "%.2f dB" : "%.4f", v);
        return std::string(text);
      };
      rows.push_back({db ? "PSNR" : "SSIM", cell(q.mean), cell(q.p50), cell(q.worst),
                      std::to_string(q.frames)});
    }
    body +=
        "<h2>Quality against the truth</h2>\n<p>Each written frame against the synthetic scene's "
        "true image "
        "from the same view, inside its true mask. Judging took " +
        format(percentile(judge_ms_, 50), " ms") +
        " per frame (p50), after the frame was written and before the next.</p>\n" +
        html::table({"measure", "mean", "p50", "worst", "frames"}, rows);
  }
  const double n = std::max<double>(1.0, static_cast<double>(frames_.size()));
  body += html::barChart(
      "Bytes per frame by link", {"pods -> server", "server -> client", "of which feather maps"},
      {{"KB per frame",
        {pod_bytes / n / 1000.0, client_bytes / n / 1000.0, feather_bytes / n / 1000.0}}},
      "KB");
  const auto jitter = podJitterMs();
  if (!jitter.empty()) {
    std::vector<std::string> pods;
    html::Series series{"RFC 3550 jitter", {}};
    for (const auto& [pod, ms] : jitter) {
      pods.push_back("pod " + std::to_string(pod));
      series.values.push_back(ms);
    }
    body += html::barChart(jitterFromServer()
                               ? "Arrival jitter per pod (at the server, every frame)"
                               : "Arrival jitter per pod (frames behind rendered meshes)",
                           pods, {series}, "ms");
  }
  const std::vector<HostClock> clocks = hostClocks();
  if (!clocks.empty()) {
    std::vector<std::vector<std::string>> rows;
    auto ms3 = [](double v, bool sign) {
      char text[32];
      std::snprintf(text, sizeof text, sign ? "%+.3f ms" : "%.3f ms", v);
      return std::string(text);
    };
    for (const HostClock& c : clocks) {
      if (!c.measured) {
        rows.push_back({c.host, "not measured (a peer before protocol 1.8)", "", "", ""});
        continue;
      }
      rows.push_back({(c.drifted ? "!" : "") + c.host, ms3(c.offset_ms, true),
                      ms3(c.uncertainty_ms, false), ms3(c.driftMs(), true),
                      c.drifted ? "DRIFTED" : "steady"});
    }
    body +=
        "<h2>Clocks against the server's</h2>\n<p>Every stamp above is on the server's "
        "clock: each host's times are moved by its offset, estimated from NTP-style probes "
        "(the smallest round trip of the last eight). A clock that moves more than " +
        ms3(clock_drift_warn_ms_, false) + " beyond the estimates' uncertainty is flagged.</p>\n" +
        html::table({"host", "offset", "uncertainty", "drift", "state"}, rows);
  }
  if (!mask_health_.frame_ids.empty()) {
    std::vector<std::vector<std::string>> rows;
    for (size_t c = 0; c < mask_health_.cameras.size(); ++c) {
      const HealthOverTime::Camera& camera = mask_health_.cameras[c];
      char min[16], median[16];
      std::snprintf(min, sizeof(min), "%.3f", camera.min);
      std::snprintf(median, sizeof(median), "%.3f", camera.median);
      const std::string id = std::to_string(c < mask_health_ids_.size() ? mask_health_ids_[c] : c);
      rows.push_back({(camera.concern.empty() ? "" : "!") + id, min, median,
                      std::to_string(camera.bad_frames.size()),
                      camera.concern.empty() ? "agrees with the rest" : camera.concern});
    }
    body += "<h2>Each pod's mask against the fused hull</h2>\n<p>On " +
            std::to_string(mask_health_.frame_ids.size()) +
            " frames, about one a second: each pod's mask IoU with the hull's silhouette in its "
            "camera. A mask under that frame's median by " +
            std::to_string(static_cast<int>(100 * kHealthGap)) +
            " points is set apart (a prop or a light only it sees, or a part of the subject it "
            "misses).</p>\n" +
            html::table({"camera", "IoU min", "IoU median", "frames set apart", "verdict"}, rows);
  }
  if (!budget.empty()) {
    std::vector<std::vector<std::string>> rows;
    for (const auto& [name, ms] : budget) {
      if (!stageMeasured(name)) {
        rows.push_back(
            {name, format(ms, " ms"), "n/a", "n/a", "not measured: no sample in this run"});
        continue;
      }
      const double p95_ms = stagePercentile(name, 95);
      rows.push_back({(p95_ms > ms ? "!" : "") + name, format(ms, " ms"),
                      format(stagePercentile(name, 50), " ms"), format(p95_ms, " ms"),
                      p95_ms > ms ? "OVER" : "within"});
    }
    body += "<h2>Budget</h2>\n" +
            html::table({"stage", "budget", "p50", "p95", "p95 against budget"}, rows);
  }
  return html::page("holofuse live loop report", body);
}

}  // namespace holofuse::render
