// The live loop's launcher, its run: starts the server, the pods and the
// clients of a plan (deploy/loop_plan.h) as separate processes, each in a
// network namespace of its own with --netns, relays the client's progress,
// and stops everything cleanly when the client has its frames, the soak
// its minutes, or on Ctrl-C, leaving no process or namespace behind.
#pragma once

#include "deploy/loop_plan.h"

namespace holofuse::deploy {

// The exit code: 0 when every process did its part.
int runLoop(LoopPlan& plan);

}  // namespace holofuse::deploy
