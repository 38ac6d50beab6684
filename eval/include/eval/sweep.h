// The speed/accuracy trade, swept one knob at a time around the defaults:
// each point is a leave-one-camera-out run (eval/leave_one_out.h) with one
// setting changed, reported as quality against client time, pipeline time
// and bytes per frame, with the Pareto front marked and the defaults
// checked against it.
//
// Interrupting a sweep loses at most the point in progress: each finished
// point is written to <out>/points/<knob>=<value>.json (atomically, by
// rename) and a rerun with the same --out skips the points already there.
// Every knob's default value is the same run: it is done once and kept in
// points/default.json.
//
// With live_frames, each point also runs the live loop (holofuse_loop, real
// processes on loopback) with the point's settings for that many frames,
// into <out>/live/<knob>=<value>/, and keeps its end-to-end latency (the
// time from capture to the written frame, network and queues included),
// every stage's p95 and each pod's arrival jitter: what the leave-one-out
// run cannot see. The point's leave-one-out result is written before its
// live run starts, so a live run that fails or is cut short loses only itself.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "eval/knobs.h"
#include "eval/leave_one_out.h"

namespace holofuse::eval {

struct SweepOptions {
  EvalOptions base;
  std::vector<std::pair<std::string, std::vector<std::string>>> knobs;  // name, values
  std::string out_dir;
  int live_frames = 0;       // 0: no live runs
  std::string loop_program;  // holofuse_loop, for the live runs
};

// A point run live: the client's end-to-end latency and frame rate, the
// p95 of every stage the run stamped, and each pod's arrival jitter.
struct LiveMeasure {
  int frames = 0;  // rendered
  double end_to_end_ms_p50 = 0, end_to_end_ms_p95 = 0, fps = 0;
  // report.json latency_ms.stages' p95 of each stage with samples, and
  // "end_to_end"; what a budget's stages are held against live.
  std::map<std::string, double> stage_ms_p95;
  // report.json jitter_ms: "pod_<N>" -> RFC 3550 interarrival jitter, ms.
  std::map<std::string, double> jitter_ms;
  std::string report;  // its report.json
};

struct SweepPoint {
  std::string knob, value;
  bool is_default = false;
  bool resumed = false;  // read back from a previous run
  SceneResult result;    // the first scene of the sweep
  std::optional<LiveMeasure> live;
};

// A point's budget: each stage the leave-one-out run times held against it
// at p95 (checkBudget), then each other budgeted stage (end_to_end,
// upload, ...) against the point's live run when it has one (mode "live");
// unchecked names the budgeted stages neither measured.
struct PointBudget {
  std::vector<BudgetCheck> checks;
  std::vector<std::string> unchecked;
};
PointBudget checkPointBudget(const protocol::Budget& budget, const SweepPoint& point,
                             const std::string& mode);

// Validates every knob and value before running anything (an error of
// code kMalformed, as is a point on disk measured under other settings; a
// knob given twice is refused). A knob whose values leave out its default
// gets the default as one more point, so that the report can place it.
// A live run that fails, or renders fewer frames than asked, is an error
// naming its log; the points before it stay on disk.
StatusOr<std::vector<SweepPoint>> runSweep(
    const SweepOptions& options, const std::function<void(const std::string&)>& progress = {});

// The scene or dataset folder a sweep runs on.
std::string sweptSubject(const SweepOptions& options);

// The mode whose quality the trade-off plots (the last of the modes asked for).
std::string primaryMode(const EvalOptions& options);
// The bytes a frame takes to a client of the mode (texture layers for
// mode layered, the scene's images otherwise; a result written before
// the modes counted their own: the scene's).
double clientBytes(const SceneResult& result, const ModeResult& mode);

// Hull + codecs + client ms per new mesh: the per-frame work that moves
// with the knobs; at p50, or at p95 (each part's p95, added).
double pipelineMs(const SceneResult& result, const std::string& mode, bool p95 = false);

// What the sweep counts as a gain, since its points are measured one after
// another on a machine whose speed drifts: times must differ by more than
// 10% and by more than either point's p50-to-p95 spread; PSNR by more than
// 0.01 dB; SSIM by more than 0.001; bytes by more than 0.5%.
inline constexpr double kTimeTieShare = 0.10, kPsnrTieDb = 0.01, kBytesTieShare = 0.005;
inline constexpr double kSsimTie = 0.001;

// One cost of a point: its median and 95th percentile (equal for exact
// costs such as bytes), and the share under which two values tie.
struct Cost {
  double p50 = 0, p95 = 0;
  double tie_share = kTimeTieShare;
};
inline Cost timeCost(double p50, double p95) { return {p50, p95, kTimeTieShare}; }
inline Cost bytesCost(double bytes) { return {bytes, bytes, kBytesTieShare}; }

struct TradePoint {
  double psnr_db = 0;
  std::vector<Cost> costs;  // the same costs, in the same order, for every point compared
  // The other quality, judged beside PSNR where both points have it: a
  // sharper picture at the same PSNR is a gain (-1: not measured).
  double ssim = -1;
};

// a dominates b: no worse than b in quality and in every cost, as
// measured, and better in one beyond a tie.
bool dominates(const TradePoint& a, const TradePoint& b);

// Indices of the points no other point dominates.
std::vector<size_t> paretoFront(const std::vector<TradePoint>& points);

// sweep.json, sweep.md and sweep.html (table, Pareto plots per knob, and
// whether the default sits on the front or which point dominates it).
Status writeSweepReports(const SweepOptions& options, const std::vector<SweepPoint>& points);

}  // namespace holofuse::eval
