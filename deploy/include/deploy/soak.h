// A soak of the live loop (./holofuse soak): every process's resident
// memory, descriptors and threads sampled while the loop runs for a long
// time, judged flat or not after a warm-up, and written for people
// (soak.md, soak.html with a chart) and programs (soak.json).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "base/process.h"
#include "deploy/heap_profile.h"

namespace holofuse::deploy {

struct SoakSample {
  double minute = 0;      // since the loop started
  uint64_t sessions = 0;  // client sessions begun by then (a churning soak's)
  // Per process, in the order of the names judged with it; nullopt: the
  // process was gone.
  std::vector<std::optional<ProcessUsage>> usage;
};

// A straight line through a quantity against time, fitted robustly:
// Theil and Sen's slope, the median of the slopes between every pair of
// samples (a lone spike moves it little), with its 95% confidence
// interval from Kendall's tau (Sen 1968). Per hour.
struct TrendFit {
  double slope = 0, low = 0, high = 0;
  double intercept = 0;  // the line's value at hour 0
  size_t samples = 0;
};
// hours and values side by side; long series are first averaged in runs
// of consecutive samples down to at most kTrendPoints points.
inline constexpr size_t kTrendPoints = 400;
TrendFit fitTrend(const std::vector<double>& hours, const std::vector<double>& values);

enum class TrendVerdict { kFlat, kLeaking, kUndecided };
const char* trendVerdictName(TrendVerdict verdict);  // "flat", "leaking", "undecided"

// One quantity of one process after the warm-up, against its limit:
// flat when the whole interval lies under the limit, leaking when it lies
// above, undecided when it straddles it.
struct SoakTrend {
  std::string process, quantity;  // quantity: "rss_mb", "descriptors", "threads"
  double first = 0, last = 0, min = 0, max = 0;
  TrendFit fit;  // per "h" or per "100 sessions" (per)
  std::string per = "h";
  double limit = 0;  // per the same
  TrendVerdict verdict = TrendVerdict::kUndecided;
  // Undecided: how long a run after the warm-up would decide, in hours or
  // hundreds of sessions (the interval narrows as the run's length to the
  // power 3/2; with a margin of 1.5); infinity when the slope sits at the
  // limit.
  double to_decide = 0;
  bool flat() const { return verdict == TrendVerdict::kFlat; }
};

// The limits: memory may grow by at most kMemoryLimitShare of its level
// (the median after the warm-up) an hour, and at least by
// kMemoryLimitFloorPerHour, 0.22 MB/h for a 45 MB server
// (a 1%-an-hour leak is twice that); descriptors and threads by at most
// kCountLimitPerHour.
inline constexpr double kMemoryLimitShare = 0.005, kCountLimitPerHour = 0.5;
// A small heap's share would ask for less than any soak can measure (a
// server whose heap between frames is 0.2 MB: 1 KB/h); memory may always
// grow by this much, MB an hour.
inline constexpr double kMemoryLimitFloorPerHour = 0.05;
// A churning soak's server, against the sessions begun: at most 1 KB of
// memory a session (0.1 MB per 100), a descriptor or thread per 100.
inline constexpr double kMemoryLimitPer100Sessions = 0.1, kCountLimitPer100Sessions = 1.0;

// What a churning soak did, and what the server said it saw (its log's
// joins, leaves and refusals of clients): every action accounted for.
struct ChurnCounts {
  uint64_t sessions = 0, sessions_bye = 0, sessions_killed = 0, sessions_failed = 0;
  uint64_t pod_restarts = 0, pod_restarts_killed = 0;
  // In a rig: pod 0's link cut (and later restored); cuts that failed.
  uint64_t link_cuts = 0, link_restores = 0, link_cut_failures = 0;
  uint64_t server_client_joins = 0, server_client_leaves = 0, server_refusals = 0;
  uint64_t server_pod_joins = 0, server_pod_leaves = 0;
  // The server's descriptors and threads once the last session left,
  // against where they were when the first session began.
  int descriptors_start = 0, descriptors_end = 0, threads_start = 0, threads_end = 0;
};

struct SoakVerdict {
  // No quantity leaking, every process alive, enough samples: what the
  // soak's exit code says. Undecided quantities do not fail it; they are
  // listed in undecided with the run length that would decide.
  bool passed = false;
  bool flat = false;  // passed, and every quantity decided flat
  std::vector<SoakTrend> trends;
  std::vector<std::string> problems;   // in words: what leaks, who died, too short to tell
  std::vector<std::string> undecided;  // in words, with the run that would decide
};

// Every process alive in every sample; after warmup_minutes each quantity
// judged by its trend against its limit. At least three samples after
// the warm-up are needed to tell.
// Processes named in restarted (a churning soak's pod) are several
// processes in turn: checked alive, never judged by trend.
SoakVerdict judgeSoak(const std::vector<std::string>& processes,
                      const std::vector<SoakSample>& samples, double warmup_minutes,
                      const std::vector<std::string>& restarted = {});

struct SoakReport {
  std::string settings;  // the run, in words (pods, clients, size, fps, minutes)
  std::vector<std::string> processes;
  std::vector<SoakSample> samples;
  double warmup_minutes = 0;
  SoakVerdict verdict;
  std::optional<ChurnCounts> churn;
  std::vector<std::string> restarted;  // judgeSoak's
  // With --profile: the server's allocation sites whose held memory grew
  // from the warm-up's end to the last sample (heaptrack), or why none.
  std::optional<HeapGrowth> heap_growth;
  std::string heap_profile_problem;
};

// soak.json, soak.md and soak.html into folder; false after saying why
// on stderr.
bool writeSoakReport(const SoakReport& report, const std::string& folder);

}  // namespace holofuse::deploy
