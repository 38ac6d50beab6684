// SIGINT/SIGTERM handling shared by the executables: the handler only sets
// a flag; loops poll with short timeouts and close cleanly (Bye) when set.
#pragma once

namespace holofuse {

// Installs the handlers (without SA_RESTART, so poll returns early) and
// ignores SIGPIPE.
void installStopSignals();
bool stopRequested();
// Lets a component request the same clean stop (e.g. after its last frame).
void requestStop();

}  // namespace holofuse
