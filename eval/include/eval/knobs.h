// The settings a user trades speed against accuracy with ("knobs"): one
// table that holofuse_sweep turns one at a time, holofuse_eval takes as
// flags, and the live loop takes under the same flag names, so that a
// setting measured one way can be reproduced the others.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "config/settings.h"
#include "eval/leave_one_out.h"

namespace holofuse::eval {

struct Knob {
  std::string name, meaning;
  // The flag of `./holofuse demo` that sets the same thing in the live
  // loop, so that a point can be run live; holofuse_eval takes it too.
  std::string loop_flag;
  // Sets the value on options; returns "" or what is wrong with the value.
  std::function<std::string(EvalOptions&, const std::string&)> apply;
  // The value options hold now, as the sweep spells it.
  std::function<std::string(const EvalOptions&)> current;
  // Only synthetic scenes have it (the pod count, the rendered size): a
  // dataset's cameras and image size are recorded.
  bool synthetic_only = false;
};

const std::vector<Knob>& sweepKnobs();
const Knob* findKnob(const std::string& name);
std::string knobNames();

// The pods a run has: its own count, or its scene's (cameras 0).
int camerasOf(const EvalOptions& options);

// Eval's flags of the settings it shares with the live loop (loopFlags(),
// on EvalOptions::loop; a voxel given overrides a dataset's own) and
// --pods, a synthetic scene's camera count; every knob but size is one.
const std::vector<Setting<EvalOptions>>& evalFlags();

}  // namespace holofuse::eval
