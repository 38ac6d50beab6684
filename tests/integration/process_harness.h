// Real processes for the integration tests: start an executable with its
// output in a log file, wait for it with a limit, fresh folders, and a
// fusion server on a port of its own choosing.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
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
// Polls until done() holds, for at most limit_s; false when it never did.
// What a test waits for is an event (a line in a log, a picture written),
// never a stretch of time.
bool waitFor(const std::function<bool()>& done, int limit_s = 60);
// The PNGs a render client has written under its --out folder.
size_t picturesIn(const fs::path& client_out);
bool logSays(const fs::path& log, const std::string& what);
// A report or result the programs wrote (report.json, quality.json).
nlohmann::json readJson(const fs::path& p);
// A free TCP port on loopback (bound, read back, released); 0: none.
uint16_t freePort();

// Built with ASan or TSan: the programs run several times slower and hold
// shadow memory and a quarantine of freed blocks, so a live rig's rate and
// its resident sizes are not the program's own.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
// A fusion_server for `pods` pods on a free port (extra flags appended);
// returns "127.0.0.1:PORT", or empty when it did not report its port.
std::string startServer(const std::string& bin_dir, const fs::path& out, int pods, pid_t* pid,
                        const std::vector<std::string>& extra = {},
                        const std::vector<std::string>& wrapper = {});

// The small rig many loop tests run: pods of 64x48 at 10 fps (log
// pod<id>.log unless log_name is given), clients rendering 64x48 into
// out/name (log name.log).
inline constexpr int kSmallWidth = 64, kSmallHeight = 48;
pid_t startSmallPod(const std::string& bin_dir, const std::string& endpoint, int id, int pods,
                    const fs::path& out, const std::vector<std::string>& extra = {},
                    const std::string& log_name = "");
pid_t startSmallClient(const std::string& bin_dir, const std::string& endpoint, const fs::path& out,
                       const std::string& name, int frames,
                       const std::vector<std::string>& extra = {});

}  // namespace holofuse::test
