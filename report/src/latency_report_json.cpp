// report.json: the layout docs/report-json.md documents, key order kept.
#include <algorithm>
#include <nlohmann/json.hpp>

#include "base/statistics.h"
#include "report/latency_report.h"

namespace holofuse::report {
namespace {

using Json = nlohmann::ordered_json;

using Series = DecimatedSeries<double>;

// samples: every one taken; the percentiles are over those kept (all of
// them until 2048, then an even spread, base/decimated_series.h).
Json spreadOf(const Series& ms) {
  return {{"p50", percentile(ms.kept(), 50)},
          {"p95", percentile(ms.kept(), 95)},
          {"samples", ms.count()}};
}

// Every pipeline stage in order (those without a sample too), then the
// stages outside the pipeline that have one.
Json stagesJson(const std::map<uint16_t, Series>& stage_ms) {
  Json stages = Json::object();
  const Series none;
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
Json linksJson(const std::map<uint16_t, const Series*>& transit_ms,
               const std::map<uint16_t, Series>& stage_ms) {
  Json links = Json::object();
  for (const auto& [pod, ms] : transit_ms)
    links["pod_" + std::to_string(pod) + "_to_server"] = spreadOf(*ms);
  const auto fanout = stage_ms.find(static_cast<uint16_t>(protocol::Stage::kFanout));
  if (fanout != stage_ms.end()) links["server_to_client"] = spreadOf(fanout->second);
  return links;
}

// The server's pipeline: how often it decoded a frame's pod images while
// it was still carving or encoding the frame before, and how often it
// carved a frame while it still fused the one before (fusion threads).
Json serverPipelineJson(const Series& overlap_ms, uint64_t overlapped,
                        const Series& fusion_overlap_ms, uint64_t fusion_overlapped) {
  auto spread = [](const Series& ms) {
    return Json{{"p50", percentile(ms.kept(), 50)}, {"p95", percentile(ms.kept(), 95)}};
  };
  return {
      {"frame_pairs", overlap_ms.count()},      {"overlapped", overlapped},
      {"overlap_ms", spread(overlap_ms)},       {"fusion_frame_pairs", fusion_overlap_ms.count()},
      {"fusion_overlapped", fusion_overlapped}, {"fusion_overlap_ms", spread(fusion_overlap_ms)}};
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

// The last `listed` frames in full.
Json framesJson(const std::vector<FrameRecord>& frames, size_t listed) {
  Json all = Json::array();
  for (size_t i = frames.size() - std::min(listed, frames.size()); i < frames.size(); ++i) {
    const FrameRecord& f = frames[i];
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
  j["frames_rendered"] = frames_rendered_;
  j["fps"] = fps();
  j["latency_ms"]["end_to_end"] = {{"p50", endToEndPercentile(50)},
                                   {"p95", endToEndPercentile(95)},
                                   {"p99", endToEndPercentile(99)}};
  j["latency_ms"]["stages"] = stagesJson(stage_ms_);
  // Texture-field passes on the GPU, once per new mesh (paper 000 Table 3).
  Json gpu = Json::object();
  for (const auto& [name, ms] : gpu_ms_) gpu[name] = spreadOf(ms);
  j["latency_ms"]["gpu_passes"] = gpu;
  std::map<uint16_t, const Series*> transit_ms;
  for (const auto& [pod, transit] : transit_) transit_ms[pod] = &transit.ms;
  j["latency_ms"]["links"] = linksJson(transit_ms, stage_ms_);
  j["server_pipeline"] = serverPipelineJson(server_overlap_.ms, server_overlap_.overlapped,
                                            fusion_overlap_.ms, fusion_overlap_.overlapped);
  const double n = std::max<double>(1.0, static_cast<double>(frames_rendered_));
  j["bytes_per_frame"] = {{"pod_link", pod_bytes_ / n},
                          {"client_link", client_bytes_ / n},
                          {"client_link_feather_maps", feather_bytes_ / n},
                          {"client_link_mesh", mesh_bytes_ / n}};
  j["mesh_triangles"] = {{"p50", percentile(triangles_.kept(), 50)}, {"max", most_triangles_}};
  j["frames_with_missing_cameras"] = frames_with_missing_cameras_;
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
    quality["judge_ms"] = {{"p50", percentile(judge_ms_.kept(), 50)},
                           {"p95", percentile(judge_ms_.kept(), 95)}};
  }
  j["quality"] = quality;
  j["frames_skipped"] = skippedFrames();
  j["frames_skipped_count"] = skippedCount();
  j["frames_at_start_up"] = startUpFrames();
  j["frames_at_start_up_count"] = startUpCount();
  j["frames_superseded"] = superseded_;
  j["pictures_dropped"] = pictures_dropped_;
  j["camera_views_without_subject"] = views_without_subject_;
  j["mask_health"] = maskHealthJson(mask_health_, mask_health_ids_);
  j["settings"] = settings;
  j["frames_listed"] = std::min(frames_.size(), kFramesListed);
  j["frames"] = framesJson(frames_, kFramesListed);
  return j.dump(2) + "\n";
}

}  // namespace holofuse::report
