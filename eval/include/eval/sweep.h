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
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "eval/leave_one_out.h"

namespace holofuse::eval {

struct Knob {
  std::string name, meaning;
  // The flag of `./holofuse demo` that sets the same thing in the live
  // loop, so that a point can be run live.
  std::string loop_flag;
  // Sets the value on options; returns "" or what is wrong with the value.
  std::function<std::string(EvalOptions&, const std::string&)> apply;
  // The value options hold now, as the sweep spells it.
  std::function<std::string(const EvalOptions&)> current;
};

const std::vector<Knob>& sweepKnobs();
const Knob* findKnob(const std::string& name);
std::string knobNames();

struct SweepOptions {
  EvalOptions base;
  std::vector<std::pair<std::string, std::vector<std::string>>> knobs;  // name, values
  std::string out_dir;
};

struct SweepPoint {
  std::string knob, value;
  bool is_default = false;
  bool resumed = false;  // read back from a previous run
  SceneResult result;    // the first scene of the sweep
};

// Validates every knob and value before running anything (std::invalid_argument).
std::vector<SweepPoint> runSweep(const SweepOptions& options,
                                 const std::function<void(const std::string&)>& progress = {});

// The mode whose quality the trade-off plots (the last of the modes asked for).
std::string primaryMode(const EvalOptions& options);

// Client ms per new mesh + hull ms: the per-frame work that moves with the knobs.
double pipelineMs(const SceneResult& result, const std::string& mode);

// Indices of the points no other point beats on both quality (higher) and
// cost (lower).
std::vector<size_t> paretoFront(const std::vector<std::pair<double, double>>& quality_and_cost);

// sweep.json, sweep.md and sweep.html (table, Pareto plots per knob, and
// whether the default sits on the front or which point dominates it).
void writeSweepReports(const SweepOptions& options, const std::vector<SweepPoint>& points);

}  // namespace holofuse::eval
