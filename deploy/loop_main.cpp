// holofuse_loop: the whole live loop on one machine (or a rig of network
// namespaces): its flags checked (deploy/loop_plan.h), then its processes
// started and supervised (deploy/loop_run.h).
#include "deploy/loop_plan.h"
#include "deploy/loop_run.h"

int main(int argc, char** argv) {
  holofuse::deploy::LoopPlan plan;
  if (const auto code = holofuse::deploy::parseLoopFlags(argc, argv, plan)) return *code;
  return holofuse::deploy::runLoop(plan);
}
