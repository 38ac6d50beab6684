#include "render_client/latency_report.h"

#include <algorithm>
#include <nlohmann/json.hpp>

namespace holofuse::render {

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double rank = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(values.size() - 1);
  const size_t lo = static_cast<size_t>(rank);
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (rank - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

void LatencyReport::addStamps(const std::vector<protocol::StageStamp>& stamps) {
  for (const auto& s : stamps) {
    if (s.end_ns >= s.start_ns && s.end_ns != 0) addStage(s.stage, static_cast<double>(s.end_ns - s.start_ns) / 1e6);
  }
}

void LatencyReport::addStage(uint16_t stage, double ms) { stage_ms_[stage].push_back(ms); }

void LatencyReport::addFrame(const FrameRecord& record, uint64_t written_ns) {
  frames_.push_back(record);
  written_ns_.push_back(written_ns);
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

std::string LatencyReport::toJson(const std::map<std::string, std::string>& settings) const {
  nlohmann::ordered_json j;
  j["frames_rendered"] = frames_.size();
  j["fps"] = fps();
  j["latency_ms"]["end_to_end"] = {{"p50", endToEndPercentile(50)},
                                   {"p95", endToEndPercentile(95)},
                                   {"p99", endToEndPercentile(99)}};
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();
  for (uint16_t stage = protocol::kFirstStage; stage <= protocol::kLastStage; ++stage) {
    auto it = stage_ms_.find(stage);
    const std::vector<double> none;
    const auto& v = it == stage_ms_.end() ? none : it->second;
    stages[protocol::stageName(stage)] = {{"p50", percentile(v, 50)}, {"p95", percentile(v, 95)}, {"samples", v.size()}};
  }
  for (const auto& [stage, v] : stage_ms_) {
    if (stage < protocol::kFirstStage || stage > protocol::kLastStage) {
      stages[protocol::stageName(stage)] = {{"p50", percentile(v, 50)}, {"p95", percentile(v, 95)}, {"samples", v.size()}};
    }
  }
  j["latency_ms"]["stages"] = stages;
  // Texture-field passes on the GPU, once per new mesh (paper 000 Table 3).
  nlohmann::ordered_json gpu = nlohmann::ordered_json::object();
  for (const auto& [name, v] : gpu_ms_) {
    gpu[name] = {{"p50", percentile(v, 50)}, {"p95", percentile(v, 95)}, {"samples", v.size()}};
  }
  j["latency_ms"]["gpu_passes"] = gpu;
  double pod_bytes = 0, client_bytes = 0;
  size_t incomplete = 0;
  for (const auto& f : frames_) {
    pod_bytes += static_cast<double>(f.pod_bytes);
    client_bytes += static_cast<double>(f.client_bytes);
    if (f.cameras_present < f.cameras_expected) ++incomplete;
  }
  const double n = std::max<double>(1.0, static_cast<double>(frames_.size()));
  j["bytes_per_frame"] = {{"pod_link", pod_bytes / n}, {"client_link", client_bytes / n}};
  j["frames_with_missing_cameras"] = incomplete;
  j["frames_skipped"] = skipped_;
  j["frames_superseded"] = superseded_;
  j["settings"] = settings;
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  for (const auto& f : frames_) {
    frames.push_back({{"frame_id", f.frame_id},
                      {"file", f.file},
                      {"end_to_end_ms", f.end_to_end_ms},
                      {"cameras_present", f.cameras_present},
                      {"cameras_expected", f.cameras_expected},
                      {"pod_bytes", f.pod_bytes},
                      {"client_bytes", f.client_bytes},
                      {"note", f.note}});
  }
  j["frames"] = frames;
  return j.dump(2) + "\n";
}

}  // namespace holofuse::render
