// The settings a user trades speed against accuracy with ("knobs"): one
// table that holofuse_sweep turns one at a time, holofuse_eval takes as
// flags, and the live loop takes under the same flag names, so that a
// setting measured one way can be reproduced the others.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "eval/leave_one_out.h"

namespace CLI {
class App;
class Option;
}  // namespace CLI

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

// Every knob but those named in except as a flag of app under its loop
// flag's name, with the knob's help; after parsing, apply() sets the given
// ones on options ("" or "--flag: what is wrong").
class KnobFlags {
 public:
  KnobFlags(CLI::App& app, const std::vector<std::string>& except = {});
  std::string apply(EvalOptions& options) const;

 private:
  struct Given {
    const Knob* knob = nullptr;
    CLI::Option* option = nullptr;
    std::string value;
  };
  std::vector<std::unique_ptr<Given>> flags_;  // stable addresses: CLI11 writes into value
};

}  // namespace holofuse::eval
