// A soak of the live loop (./holofuse soak): every process's resident
// memory, descriptors and threads sampled while the loop runs for a long
// time, judged flat or not after a warm-up, and written for people
// (soak.md, soak.html with a chart) and programs (soak.json).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "base/process.h"

namespace holofuse::deploy {

struct SoakSample {
  double minute = 0;  // since the loop started
  // Per process, in the order of the names judged with it; nullopt: the
  // process was gone.
  std::vector<std::optional<ProcessUsage>> usage;
};

// One quantity of one process after the warm-up.
struct SoakTrend {
  std::string process, quantity;  // quantity: "rss_mb", "descriptors", "threads"
  double first = 0, last = 0, min = 0, max = 0;
  bool flat = false;  // (max - min) within the tolerance of min
};

struct SoakVerdict {
  bool flat = false;
  std::vector<SoakTrend> trends;
  std::vector<std::string> problems;  // in words: what grew, who died, too short to tell
};

// Flat: every process alive in every sample, and after warmup_minutes each
// quantity's spread (max - min) at most tolerance x its minimum, or, for
// the counts (descriptors, threads), the last sample back at the least. At
// least two samples after the warm-up are needed to tell.
SoakVerdict judgeSoak(const std::vector<std::string>& processes,
                      const std::vector<SoakSample>& samples, double warmup_minutes,
                      double tolerance = 0.05);

struct SoakReport {
  std::string settings;  // the run, in words (pods, clients, size, fps, minutes)
  std::vector<std::string> processes;
  std::vector<SoakSample> samples;
  double warmup_minutes = 0;
  SoakVerdict verdict;
};

// soak.json, soak.md and soak.html into folder; false after saying why
// on stderr.
bool writeSoakReport(const SoakReport& report, const std::string& folder);

}  // namespace holofuse::deploy
