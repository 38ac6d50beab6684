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
      server_overlap_.add(
          earlier_end > decode_start ? static_cast<double>(earlier_end - decode_start) / 1e6 : 0.0);
    }
    last_server_span_ = {decode_start, fused_end};
  }
  // Two groups fused at once (--fusion-threads): the later one's hull
  // began before the earlier one's encodes ended.
  if (fusion_start != UINT64_MAX && fused_end >= fusion_start) {
    if (last_fusion_end_ns_) {
      fusion_overlap_.add(*last_fusion_end_ns_ > fusion_start
                              ? static_cast<double>(*last_fusion_end_ns_ - fusion_start) / 1e6
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
      PodTransit& pod = transit_[s.source];
      const double sent = static_cast<double>(s.start_ns) / 1e6;
      const double received = static_cast<double>(s.end_ns) / 1e6;
      pod.ms.add(received - sent);
      pod.pending.emplace_back(sent, received);
      if (pod.pending.size() > kJitterReorder) {
        // The earliest arrival of those waiting goes to the estimate.
        const auto first = std::min_element(pod.pending.begin(), pod.pending.end(), arrivedBefore);
        pod.jitter.add(first->first, first->second);
        pod.pending.erase(first);
      }
    }
  }
}

double LatencyReport::PodTransit::jitterMs() const {
  std::vector<std::pair<double, double>> waiting = pending;
  std::sort(waiting.begin(), waiting.end(), arrivedBefore);
  ArrivalJitter all = jitter;
  for (const auto& [sent, received] : waiting) all.add(sent, received);
  return all.ms();
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
  if (psnr_.values.empty()) return {};
  auto summary = [](const char* name, const Judged& judged) {
    const auto frames = static_cast<size_t>(judged.values.count());
    return QualitySummary{name, judged.sum / static_cast<double>(frames),
                          percentile(judged.values.kept(), 50), judged.worst, frames};
  };
  return {summary("psnr_db", psnr_), summary("ssim", ssim_)};
}

std::map<uint16_t, double> LatencyReport::podJitterMs() const {
  std::map<uint16_t, double> jitter;
  for (const auto& a : server_arrivals_) jitter[a.pod] = static_cast<double>(a.jitter_us) / 1000.0;
  if (!jitter.empty()) return jitter;
  for (const auto& [pod, transit] : transit_) jitter[pod] = transit.jitterMs();
  return jitter;
}

double LatencyReport::stagePercentile(const std::string& name, double p) const {
  if (name == "end_to_end") return endToEndPercentile(p);
  for (const auto& [stage, v] : stage_ms_) {
    if (protocol::stageName(stage) == name) return percentile(v.kept(), p);
  }
  return 0.0;
}

bool LatencyReport::stageMeasured(const std::string& name) const {
  if (name == "end_to_end") return frames_rendered_ > 0;
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

void LatencyReport::addStage(uint16_t stage, double ms) { stage_ms_[stage].add(ms); }

void LatencyReport::addFrame(const FrameRecord& record, uint64_t written_ns) {
  if (frames_rendered_ == 0) first_written_ns_ = written_ns;
  last_written_ns_ = written_ns;
  // The list is cut back to its last kFramesListed when it reaches twice
  // that, so that a frame costs one move on average.
  if (frames_.size() >= 2 * kFramesListed)
    frames_.erase(frames_.begin(), frames_.end() - static_cast<std::ptrdiff_t>(kFramesListed));
  frames_.push_back(record);
  FrameRecord& frame = frames_.back();
  frame.place = frames_rendered_++;
  end_to_end_.add({frame.capture_time_ns, frame.written_local_ns, frame.end_to_end_ms});
  pod_bytes_ += static_cast<double>(frame.pod_bytes);
  client_bytes_ += static_cast<double>(frame.client_bytes);
  feather_bytes_ += static_cast<double>(frame.feather_bytes);
  mesh_bytes_ += static_cast<double>(frame.mesh_bytes);
  if (frame.cameras_present < frame.cameras_expected) ++frames_with_missing_cameras_;
  triangles_.add(static_cast<double>(frame.mesh_triangles));
  most_triangles_ = std::max(most_triangles_, static_cast<double>(frame.mesh_triangles));
  if (frame.quality) {
    psnr_.add(frame.quality->psnr_db);
    ssim_.add(frame.quality->ssim);
  }
  if (frame.timeline.empty()) return;
  const auto slower = [](const FrameRecord& a, const FrameRecord& b) {
    return a.end_to_end_ms > b.end_to_end_ms;
  };
  if (slowest_.size() == kSlowestKept) {
    if (!slower(frame, slowest_.back())) return;
    slowest_.pop_back();
  }
  slowest_.insert(std::upper_bound(slowest_.begin(), slowest_.end(), frame, slower), frame);
}

std::vector<FrameRecord> LatencyReport::slowestFrames() const { return slowest_; }

void LatencyReport::settleEndToEnd(const protocol::ClockSync& server_clock) {
  const auto settle = [&](uint64_t capture_ns, uint64_t written_local_ns, double& end_to_end_ms) {
    if (written_local_ns == 0 || capture_ns == 0) return;
    const auto written = static_cast<int64_t>(server_clock.toPeer(written_local_ns));
    end_to_end_ms = static_cast<double>(written - static_cast<int64_t>(capture_ns)) / 1e6;
  };
  for (FrameTimes& t : end_to_end_.kept())
    settle(t.capture_ns, t.written_local_ns, t.end_to_end_ms);
  for (auto* frames : {&frames_, &slowest_})
    for (FrameRecord& f : *frames) settle(f.capture_time_ns, f.written_local_ns, f.end_to_end_ms);
  // Settled, the slowest may change order; they were chosen by the
  // estimates of their moment.
  std::stable_sort(
      slowest_.begin(), slowest_.end(),
      [](const FrameRecord& a, const FrameRecord& b) { return a.end_to_end_ms > b.end_to_end_ms; });
}

double LatencyReport::fps() const {
  if (frames_rendered_ < 2) return 0.0;
  const double seconds = static_cast<double>(last_written_ns_ - first_written_ns_) / 1e9;
  return seconds > 0 ? static_cast<double>(frames_rendered_ - 1) / seconds : 0.0;
}

double LatencyReport::endToEndPercentile(double p) const {
  std::vector<double> e2e;
  e2e.reserve(end_to_end_.kept().size());
  for (const FrameTimes& t : end_to_end_.kept()) e2e.push_back(t.end_to_end_ms);
  return percentile(std::move(e2e), p);
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

std::vector<std::string> LatencyReport::Reasons::listed() const {
  std::vector<std::string> lines = named;
  if (count > named.size())
    lines.push_back("and " + std::to_string(count - named.size()) + " more frames");
  return lines;
}

std::vector<std::string> LatencyReport::startUpFrames() const {
  return start_up_ended_ ? start_up_.listed() : std::vector<std::string>{};
}

std::vector<std::string> LatencyReport::skippedFrames() const {
  std::vector<std::string> skipped = skipped_.listed();
  if (!start_up_ended_) {
    const std::vector<std::string> start_up = start_up_.listed();
    skipped.insert(skipped.end(), start_up.begin(), start_up.end());
  }
  return skipped;
}

}  // namespace holofuse::report
