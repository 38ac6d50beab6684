#include "base/shutdown.h"

#include <signal.h>

#include <atomic>

namespace holofuse {
namespace {
std::atomic<bool> g_stop{false};
void onSignal(int) { g_stop.store(true); }
}  // namespace

void installStopSignals() {
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  signal(SIGPIPE, SIG_IGN);
}

bool stopRequested() { return g_stop.load(); }
void requestStop() { g_stop.store(true); }

}  // namespace holofuse
