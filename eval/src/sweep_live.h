// What the sweep's runner and its report share about live runs: a live
// measure as a point file keeps it, and the live loop's flags of a point.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "eval/sweep.h"

namespace holofuse::eval {

nlohmann::json liveJson(const LiveMeasure& live, int frames_asked);
// A live run kept in a point's file; none when the file's is damaged (it
// is then run again).
std::optional<LiveMeasure> liveFromJson(const nlohmann::json& j);
// The worst pod's jitter of a live run, or -1 without one.
double worstJitterMs(const std::optional<LiveMeasure>& live);
// The live loop's flags for a point: the scene, the mode, every knob the
// base moved from its default, and the point's own.
std::vector<std::string> liveArguments(const SweepOptions& options, const std::string& knob,
                                       const std::string& value);

}  // namespace holofuse::eval
