// What every loop test file starts from: the harness's names, the programs
// under test (HOLOFUSE_BIN_DIR, which each loop test executable defines),
// and the harness's starters bound to them, so that no file repeats the
// prologue or wraps the starters again.
#pragma once

#include <string>
#include <vector>

#include "process_harness.h"

namespace holofuse::test {

inline const std::string kBin = HOLOFUSE_BIN_DIR;

inline std::string startServer(const fs::path& out, int pods, pid_t* pid,
                               const std::vector<std::string>& extra = {},
                               const std::vector<std::string>& wrapper = {}) {
  return startServer(kBin, out, pods, pid, extra, wrapper);
}
inline pid_t startSmallPod(const std::string& endpoint, int id, int pods, const fs::path& out,
                           const std::vector<std::string>& extra = {},
                           const std::string& log_name = "") {
  return startSmallPod(kBin, endpoint, id, pods, out, extra, log_name);
}
inline pid_t startSmallClient(const std::string& endpoint, const fs::path& out,
                              const std::string& name, int frames,
                              const std::vector<std::string>& extra = {}) {
  return startSmallClient(kBin, endpoint, out, name, frames, extra);
}

// The launcher run with flags into out (its output in out/loop.log): its
// exit code, -1 past limit_s.
inline int runLoop(const fs::path& out, std::vector<std::string> flags, int limit_s = 240) {
  flags.insert(flags.begin(), kBin + "/holofuse_loop");
  flags.insert(flags.end(), {"--out", out.string()});
  return waitExit(spawn(flags, out / "loop.log"), limit_s);
}

// flags, and what makes a loop's pictures comparable with the truth from
// pod 0's pose: the client there, every written frame judged, the pods'
// scene at a fixed seed and without sensor noise.
inline std::vector<std::string> judgedFromPod0(std::vector<std::string> flags) {
  flags.insert(flags.end(), {"--view", "pod:0", "--quality", "--seed", "5", "--noise", "0"});
  return flags;
}

}  // namespace holofuse::test
