#include "report/latency_report.h"

#include <algorithm>
#include <cmath>

#include "base/statistics.h"

namespace holofuse::report {

double msSinceCapture(const FrameRecord& frame, uint64_t ns) {
  return static_cast<double>(static_cast<int64_t>(ns - frame.capture_time_ns)) / 1e6;
}

void LatencyReport::addStamps(const std::vector<protocol::StageStamp>& stamps) {
  using protocol::Stage;
  uint64_t decode_start = UINT64_MAX, fusion_start = UINT64_MAX, fused_end = 0;
  for (const auto& s : stamps) {
    if (s.end_ns < s.start_ns || s.end_ns == 0) continue;
    if (s.stage == static_cast<uint16_t>(Stage::kServerDecode))
      decode_start = std::min(decode_start, s.start_ns);
    if (s.stage == static_cast<uint16_t>(Stage::kHull))
      fusion_start = std::min(fusion_start, s.start_ns);
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
  // Two groups fused at once (--fusion-threads): the later one's hull
  // began before the earlier one's encodes ended.
  if (fusion_start != UINT64_MAX && fused_end >= fusion_start) {
    if (last_fusion_end_ns_) {
      fusion_overlap_ms_.push_back(*last_fusion_end_ns_ > fusion_start
                                       ? static_cast<double>(*last_fusion_end_ns_ - fusion_start) /
                                             1e6
                                       : 0.0);
    }
    last_fusion_end_ns_ = fused_end;
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

std::vector<std::string> LatencyReport::startUpFrames() const {
  return start_up_ended_ ? start_up_ : std::vector<std::string>{};
}

std::vector<std::string> LatencyReport::skippedFrames() const {
  std::vector<std::string> skipped = skipped_;
  if (!start_up_ended_) skipped.insert(skipped.end(), start_up_.begin(), start_up_.end());
  return skipped;
}

}  // namespace holofuse::report
