#include "process_harness.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <thread>

#include "base/process.h"
#include "protocol/auth.h"
#include "protocol/socket.h"

namespace holofuse::test {
namespace {

// Every process spawn() started in the running test. A test that ends
// early (a failed ASSERT) must not leave its server and pods running into
// the tests after it, taking their CPU: whatever still runs when a test
// ends is stopped then, and said so.
std::vector<pid_t>& spawnedInThisTest() {
  static std::vector<pid_t> pids;
  return pids;
}

class StopWhatTheTestLeft : public ::testing::EmptyTestEventListener {
  void OnTestEnd(const ::testing::TestInfo& info) override {
    for (const pid_t pid : spawnedInThisTest()) {
      // -1: the test reaped it already; > 0: it had ended, reaped now.
      if (::waitpid(pid, nullptr, WNOHANG) != 0) continue;
      const StoppedProcess stopped = stopProcess(pid, 2000);
      std::fprintf(stderr, "[harness] %s.%s left process %d running; stopped it%s\n",
                   info.test_suite_name(), info.name(), static_cast<int>(pid),
                   stopped.killed ? " (SIGKILL)" : "");
    }
    spawnedInThisTest().clear();
  }
};

const bool kStopsLeftovers = [] {
  ::testing::UnitTest::GetInstance()->listeners().Append(new StopWhatTheTestLeft);
  return true;
}();

}  // namespace

const std::string& testKeyFile() {
  // One fresh key per test process, in the environment every program it
  // starts inherits: the loops under test authenticate as a real rig does.
  static const std::string path = [] {
    const fs::path file =
        fs::temp_directory_path() / ("holofuse_test_" + std::to_string(getpid()) + ".key");
    fs::remove(file);
    const Status made = protocol::KeyRing::writeNew(file.string());
    if (!made.isOk()) ADD_FAILURE() << made.message();
    ::setenv("HOLOFUSE_KEY_FILE", file.string().c_str(), 1);
    return file.string();
  }();
  static const struct Remove {
    ~Remove() { fs::remove(path); }
  } remove;
  return path;
}

pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  testKeyFile();
  SpawnOptions options;
  options.log_path = log.string();
  auto pid = spawnProcess(args, options);
  if (!pid.isOk()) {
    ADD_FAILURE() << pid.status().message();
    return -1;
  }
  (void)kStopsLeftovers;
  spawnedInThisTest().push_back(*pid);
  return *pid;
}

int waitExit(pid_t pid, int timeout_s) {
  if (pid < 0) return -1;
  if (const auto code = waitProcess(pid, 1000 * timeout_s)) return *code;
  stopProcess(pid, 0);
  return -1;
}

fs::path freshDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("holofuse_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string readFile(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::string startServer(const std::string& bin_dir, const fs::path& out, int pods, pid_t* pid,
                        const std::vector<std::string>& extra,
                        const std::vector<std::string>& wrapper) {
  const fs::path port_file = out / "port";
  std::vector<std::string> args = wrapper;
  for (const std::string& arg :
       {bin_dir + "/fusion_server", std::string("--listen"), std::string("127.0.0.1:0"),
        std::string("--pods"), std::to_string(pods), std::string("--port-file"),
        port_file.string()})
    args.push_back(arg);
  args.insert(args.end(), extra.begin(), extra.end());
  *pid = spawn(args, out / "server.log");
  // The port file appears once the server listens (a sanitized server
  // takes seconds to start); a server that ended will never write it.
  std::string port;
  waitFor([&] {
    std::ifstream in(port_file);
    std::getline(in, port);
    siginfo_t ended{};  // WNOWAIT: a test may still wait for its exit code
    return !port.empty() ||
           (waitid(P_PID, static_cast<id_t>(*pid), &ended, WEXITED | WNOHANG | WNOWAIT) == 0 &&
            ended.si_pid == *pid);
  });
  return port.empty() ? std::string() : "127.0.0.1:" + port;
}

pid_t startSmallPod(const std::string& bin_dir, const std::string& endpoint, int id, int pods,
                    const fs::path& out, const std::vector<std::string>& extra,
                    const std::string& log_name) {
  std::vector<std::string> argv = {bin_dir + "/capture_node",
                                   "--server",
                                   endpoint,
                                   "--pod-id",
                                   std::to_string(id),
                                   "--pods",
                                   std::to_string(pods),
                                   "--size",
                                   std::to_string(kSmallWidth) + "x" + std::to_string(kSmallHeight),
                                   "--fps",
                                   "10"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return spawn(argv, out / (log_name.empty() ? "pod" + std::to_string(id) + ".log" : log_name));
}

pid_t startSmallClient(const std::string& bin_dir, const std::string& endpoint, const fs::path& out,
                       const std::string& name, int frames, const std::vector<std::string>& extra) {
  std::vector<std::string> argv = {
      bin_dir + "/render_client",
      "--server",
      endpoint,
      "--out",
      (out / name).string(),
      "--frames",
      std::to_string(frames),
      "--size",
      std::to_string(kSmallWidth) + "x" + std::to_string(kSmallHeight)};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return spawn(argv, out / (name + ".log"));
}

bool waitFor(const std::function<bool()>& done, int limit_s) {
  for (int i = 0; i < limit_s * 20; ++i) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return done();
}

size_t picturesIn(const fs::path& client_out) {
  size_t n = 0;
  std::error_code error;
  for (fs::directory_iterator it(client_out / "frames", error), end; !error && it != end;
       it.increment(error))
    n += it->path().extension() == ".png";
  return n;
}

nlohmann::json readJson(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

uint16_t freePort() {
  auto listener = protocol::listenTcp({"127.0.0.1", 0});
  return listener.isOk() ? listener->localPort() : 0;  // closed again on return
}

bool logSays(const fs::path& log, const std::string& what) {
  return readFile(log).find(what) != std::string::npos;
}

}  // namespace holofuse::test
