// report.json: the layout docs/report-json.md documents, key order kept.
#include <algorithm>
#include <nlohmann/json.hpp>

#include "base/statistics.h"
#include "report/latency_report.h"

namespace holofuse::report {
namespace {

using Json = nlohmann::ordered_json;

Json spreadOf(const std::vector<double>& ms) {
  return {{"p50", percentile(ms, 50)}, {"p95", percentile(ms, 95)}, {"samples", ms.size()}};
}

// Every pipeline stage in order (those without a sample too), then the
// stages outside the pipeline that have one.
Json stagesJson(const std::map<uint16_t, std::vector<double>>& stage_ms) {
  Json stages = Json::object();
  const std::vector<double> none;
  for (uint16_t stage : protocol::stagesInPipelineOrder()) {
    const auto it = stage_ms.find(stage);
    stages[protocol::stageName(stage)] = spreadOf(it == stage_ms.end() ? none : it->second);
  }
  for (const auto& [stage, ms] : stage_ms) {
    if (stage < protocol::kFirstStage || stage > protocol::kLastStage)
      stages[protocol::stageName(stage)] = spreadOf(ms);
  }
  return stages;
}

// Per link, one way: each pod's frames to the server (its send stamps
// behind rendered meshes), and the server's frames to this client (the
// fan-out, from the server's send to the arrival here).
Json linksJson(const std::map<uint16_t, std::vector<std::pair<double, double>>>& transit_ms,
               const std::map<uint16_t, std::vector<double>>& stage_ms) {
  Json links = Json::object();
  for (const auto& [pod, pairs] : transit_ms) {
    std::vector<double> ms;
    for (const auto& [sent, received] : pairs) ms.push_back(received - sent);
    links["pod_" + std::to_string(pod) + "_to_server"] = spreadOf(ms);
  }
  const auto fanout = stage_ms.find(static_cast<uint16_t>(protocol::Stage::kFanout));
  if (fanout != stage_ms.end()) links["server_to_client"] = spreadOf(fanout->second);
  return links;
}

// The server's pipeline: how often it decoded a frame's pod images while
// it was still carving or encoding the frame before, and how often it
// carved a frame while it still fused the one before (fusion threads).
Json serverPipelineJson(const std::vector<double>& overlap_ms,
                        const std::vector<double>& fusion_overlap_ms) {
  auto overlapped = [](const std::vector<double>& ms) {
    return std::count_if(ms.begin(), ms.end(), [](double v) { return v > 0; });
  };
  auto spread = [](const std::vector<double>& ms) {
    return Json{{"p50", percentile(ms, 50)}, {"p95", percentile(ms, 95)}};
  };
  return {{"frame_pairs", overlap_ms.size()},
          {"overlapped", overlapped(overlap_ms)},
          {"overlap_ms", spread(overlap_ms)},
          {"fusion_frame_pairs", fusion_overlap_ms.size()},
          {"fusion_overlapped", overlapped(fusion_overlap_ms)},
          {"fusion_overlap_ms", spread(fusion_overlap_ms)}};
}

void addBytesAndMeshes(const std::vector<FrameRecord>& frames, Json& j) {
  double pod_bytes = 0, client_bytes = 0, feather_bytes = 0, mesh_bytes = 0;
  std::vector<double> triangles;
  size_t incomplete = 0;
  for (const auto& f : frames) {
    pod_bytes += static_cast<double>(f.pod_bytes);
    client_bytes += static_cast<double>(f.client_bytes);
    feather_bytes += static_cast<double>(f.feather_bytes);
    mesh_bytes += static_cast<double>(f.mesh_bytes);
    triangles.push_back(static_cast<double>(f.mesh_triangles));
    if (f.cameras_present < f.cameras_expected) ++incomplete;
  }
  const double n = std::max<double>(1.0, static_cast<double>(frames.size()));
  j["bytes_per_frame"] = {{"pod_link", pod_bytes / n},
                          {"client_link", client_bytes / n},
                          {"client_link_feather_maps", feather_bytes / n},
                          {"client_link_mesh", mesh_bytes / n}};
  j["mesh_triangles"] = {{"p50", percentile(triangles, 50)}, {"max", percentile(triangles, 100)}};
  j["frames_with_missing_cameras"] = incomplete;
}

Json hostsJson(const std::vector<LatencyReport::HostClock>& clocks) {
  Json hosts = Json::object();
  for (const LatencyReport::HostClock& c : clocks) {
    std::string key = c.host;
    std::replace(key.begin(), key.end(), ' ', '_');
    if (!c.measured) {
      hosts[key] = {{"measured", false}};
      continue;
    }
    hosts[key] = {{"measured", true},
                  {"offset_ms", c.offset_ms},
                  {"uncertainty_ms", c.uncertainty_ms},
                  {"drift_ms", c.driftMs()},
                  {"drifted", c.drifted}};
  }
  return hosts;
}

// Each pod's mask against the fused hull, sampled about once a second.
Json maskHealthJson(const HealthOverTime& health, const std::vector<uint32_t>& camera_ids) {
  Json j = Json::object();
  j["frames_measured"] = health.frame_ids;
  j["cameras"] = Json::array();
  for (size_t c = 0; c < health.cameras.size(); ++c) {
    const HealthOverTime::Camera& camera = health.cameras[c];
    Json entry;
    entry["camera"] = c < camera_ids.size() ? camera_ids[c] : c;
    entry["iou_min"] = camera.min;
    entry["iou_median"] = camera.median;
    entry["frames_set_apart"] = camera.bad_frames;
    entry["concern"] = camera.concern;
    j["cameras"].push_back(entry);
  }
  return j;
}

Json framesJson(const std::vector<FrameRecord>& frames) {
  Json all = Json::array();
  for (const auto& f : frames) {
    Json timeline = Json::object();
    for (const auto& s : f.timeline)
      timeline[protocol::stageName(s.stage)] = {msSinceCapture(f, s.start_ns),
                                                msSinceCapture(f, s.end_ns)};
    all.push_back({{"frame_id", f.frame_id},
                   {"file", f.file},
                   {"end_to_end_ms", f.end_to_end_ms},
                   {"cameras_present", f.cameras_present},
                   {"cameras_expected", f.cameras_expected},
                   {"pod_bytes", f.pod_bytes},
                   {"client_bytes", f.client_bytes},
                   {"mesh_bytes", f.mesh_bytes},
                   {"mesh_triangles", f.mesh_triangles},
                   {"psnr_db", f.quality ? Json(f.quality->psnr_db) : Json()},
                   {"ssim", f.quality ? Json(f.quality->ssim) : Json()},
                   {"note", f.note},
                   {"timeline_ms", timeline}});
  }
  return all;
}

}  // namespace

std::string LatencyReport::toJson(const std::map<std::string, std::string>& settings,
                                  const Budget& budget) const {
  Json j;
  j["frames_rendered"] = frames_.size();
  j["fps"] = fps();
  j["latency_ms"]["end_to_end"] = {{"p50", endToEndPercentile(50)},
                                   {"p95", endToEndPercentile(95)},
                                   {"p99", endToEndPercentile(99)}};
  j["latency_ms"]["stages"] = stagesJson(stage_ms_);
  // Texture-field passes on the GPU, once per new mesh (paper 000 Table 3).
  Json gpu = Json::object();
  for (const auto& [name, ms] : gpu_ms_) gpu[name] = spreadOf(ms);
  j["latency_ms"]["gpu_passes"] = gpu;
  j["latency_ms"]["links"] = linksJson(transit_ms_, stage_ms_);
  j["server_pipeline"] = serverPipelineJson(server_overlap_ms_, fusion_overlap_ms_);
  addBytesAndMeshes(frames_, j);
  Json jitter = Json::object();
  for (const auto& [pod, ms] : podJitterMs()) jitter["pod_" + std::to_string(pod)] = ms;
  j["jitter_ms"] = jitter;
  if (jitterFromServer()) {
    j["jitter_source"] = "server, over every pod frame received";
    Json received = Json::object();
    for (const auto& a : server_arrivals_) received["pod_" + std::to_string(a.pod)] = a.frames;
    j["pod_frames_at_server"] = received;
  } else if (!jitter.empty()) {
    j["jitter_source"] =
        "client, over the pod frames behind rendered meshes (the server sent no arrivals)";
  }
  // Every host's clock against the server's, which the stamps are on.
  j["clocks"] = {{"against", "the server's CLOCK_MONOTONIC, which every stamp is on"},
                 {"drift_warn_ms", clock_drift_warn_ms_},
                 {"hosts", hostsJson(hostClocks())},
                 {"warnings", clockWarnings()}};
  if (!budget.empty()) {
    j["budget_ms"] = budget;
    Json over = Json::array();
    for (const auto& v : violations(budget))
      over.push_back({{"stage", v.stage}, {"p95", v.p95}, {"budget", v.budget}});
    j["budget_violations"] = over;
    j["budget_unmeasured"] = unmeasured(budget);
  }
  // Each judged frame against the truth from its view (--truth-scene).
  Json quality = Json::object();
  for (const auto& q : this->quality()) {
    quality[q.measure] = {
        {"mean", q.mean}, {"p50", q.p50}, {"worst", q.worst}, {"frames", q.frames}};
  }
  if (!judge_ms_.empty()) {
    quality["judge_ms"] = {{"p50", percentile(judge_ms_, 50)}, {"p95", percentile(judge_ms_, 95)}};
  }
  j["quality"] = quality;
  j["frames_skipped"] = skippedFrames();
  j["frames_at_start_up"] = startUpFrames();
  j["frames_superseded"] = superseded_;
  j["pictures_dropped"] = pictures_dropped_;
  j["camera_views_without_subject"] = views_without_subject_;
  j["mask_health"] = maskHealthJson(mask_health_, mask_health_ids_);
  j["settings"] = settings;
  j["frames"] = framesJson(frames_);
  return j.dump(2) + "\n";
}

}  // namespace holofuse::report
