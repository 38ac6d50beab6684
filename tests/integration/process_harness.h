// Real processes for the integration tests: start an executable with its
// output in a log file, wait for it with a limit, fresh folders, and a
// fusion server on a port of its own choosing.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace holofuse::test {

namespace fs = std::filesystem;

// Starts args[0] with args; stdout and stderr go to log.
pid_t spawn(const std::vector<std::string>& args, const fs::path& log);

// This test process's key file, made on first use and named in
// $HOLOFUSE_KEY_FILE, so every program spawn() starts authenticates with it.
const std::string& testKeyFile();
// The exit code, 128 + signal when killed, or -1 after timeout_s (the
// process is then killed).
int waitExit(pid_t pid, int timeout_s);
// An empty folder under the temporary directory, unique to this process.
fs::path freshDir(const std::string& name);
std::string readFile(const fs::path& p);
// A fusion_server for `pods` pods on a free port (extra flags appended);
// returns "127.0.0.1:PORT", or empty when it did not report its port.
std::string startServer(const std::string& bin_dir, const fs::path& out, int pods, pid_t* pid,
                        const std::vector<std::string>& extra = {},
                        const std::vector<std::string>& wrapper = {});

}  // namespace holofuse::test
