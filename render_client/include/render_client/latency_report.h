// LatencyReport collects what the client learns per frame (stage stamps
// from every process, end-to-end latency, bytes per link) and writes
// report.json in the layout README.md documents.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "protocol/messages.h"

namespace holofuse::render {

struct FrameRecord {
  uint64_t frame_id = 0;
  std::string file;
  double end_to_end_ms = 0;
  uint32_t cameras_present = 0;
  uint32_t cameras_expected = 0;
  uint64_t pod_bytes = 0;
  uint64_t client_bytes = 0;
  std::string note;
};

// p in [0, 100]; linear interpolation between order statistics. 0 for none.
double percentile(std::vector<double> values, double p);

class LatencyReport {
 public:
  void addStamps(const std::vector<protocol::StageStamp>& stamps);
  void addStage(uint16_t stage, double ms);
  // GPU time of a texture-field pass (timestamp queries), by pass name.
  void addGpuPass(const std::string& name, double ms) { gpu_ms_[name].push_back(ms); }
  void addFrame(const FrameRecord& record, uint64_t written_ns);
  void noteSkipped(const std::string& why) { skipped_.push_back(why); }
  // Meshes not rendered because a newer one had already arrived.
  void setSuperseded(uint64_t count) { superseded_ = count; }

  size_t framesRendered() const { return frames_.size(); }
  double fps() const;
  double endToEndPercentile(double p) const;
  const std::vector<FrameRecord>& frames() const { return frames_; }
  // The report as JSON text.
  std::string toJson(const std::map<std::string, std::string>& settings) const;

 private:
  std::map<uint16_t, std::vector<double>> stage_ms_;
  std::map<std::string, std::vector<double>> gpu_ms_;
  std::vector<FrameRecord> frames_;
  std::vector<uint64_t> written_ns_;
  std::vector<std::string> skipped_;
  uint64_t superseded_ = 0;
};

}  // namespace holofuse::render
