// holofuse_loop: starts the whole live loop on localhost as separate
// processes (one fusion_server, N capture_node pods, one render_client),
// relays the client's progress, and stops everything cleanly when the
// client has its frames or on Ctrl-C, leaving no process behind.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "capture_node/scene_library.h"

namespace {

volatile sig_atomic_t g_interrupted = 0;
void onSignal(int) { g_interrupted = 1; }

pid_t spawn(const std::vector<std::string>& args, const std::string& log_path) {
  const pid_t pid = fork();
  if (pid != 0) return pid;
  // Child: own stdout stays the terminal for the client; pods and server log
  // to files so the progress line stays readable.
  signal(SIGINT, SIG_IGN);  // the launcher decides when children stop
  if (!log_path.empty()) {
    std::FILE* log = std::fopen(log_path.c_str(), "w");
    if (log != nullptr) {
      dup2(fileno(log), STDERR_FILENO);
      if (args[0].find("render_client") == std::string::npos) dup2(fileno(log), STDOUT_FILENO);
    }
  }
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  execv(argv[0], argv.data());
  std::perror(("cannot start " + args[0]).c_str());
  _exit(127);
}

bool waitFor(pid_t pid, int timeout_ms, int* status) {
  for (int waited = 0; waited <= timeout_ms; waited += 20) {
    if (waitpid(pid, status, WNOHANG) == pid) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

void stop(pid_t pid, const char* what) {
  if (pid <= 0) return;
  int status = 0;
  if (waitpid(pid, &status, WNOHANG) == pid) return;
  kill(pid, SIGTERM);
  if (!waitFor(pid, 3000, &status)) {
    std::fprintf(stderr, "[loop] %s (pid %d) ignored SIGTERM for 3 s; killing it\n", what, pid);
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int pods = 4, frames = 40, port = 0;
  double fps = 5.0;
  std::string size = "320x240", out = "out/demo", bin_dir, mode = "normal", view = "orbit", scene = "clean";
  CLI::App app{"holofuse loop: pods -> fusion server -> render client on localhost"};
  app.add_option("--pods", pods, "camera pods (1..16)")->check(CLI::Range(1, 16));
  app.add_option("--frames", frames, "frames the client renders before everything stops")->check(CLI::Range(1, 1000000));
  app.add_option("--size", size, "pod image and output size WxH");
  app.add_option("--fps", fps, "pod frame rate")->check(CLI::Range(0.5, 120.0));
  app.add_option("--out", out, "output folder");
  app.add_option("--port", port, "server port (0: any free port)")->check(CLI::Range(0, 65535));
  app.add_option("--mode", mode, "blending mode of the client");
  app.add_option("--view", view, "client view: orbit or pod:N");
  app.add_option("--scene", scene, "named synthetic scene (its camera count unless --pods): " + holofuse::capture::sceneNames());
  std::string budget;
  app.add_option("--budget", budget, "JSON of per-stage ms budgets for the client's report (flags violations)");
  app.add_option("--bin-dir", bin_dir, "folder of the executables (default: next to this one)");
  CLI11_PARSE(app, argc, argv);
  const holofuse::capture::ScenePreset* preset = holofuse::capture::findScene(scene);
  if (preset == nullptr) {
    std::fprintf(stderr, "--scene '%s': unknown; valid scenes: %s\n", scene.c_str(), holofuse::capture::sceneNames().c_str());
    return 2;
  }
  if (app.count("--scene") && !app.count("--pods")) pods = preset->cameras;
  namespace fs = std::filesystem;
  if (bin_dir.empty()) bin_dir = fs::canonical("/proc/self/exe").parent_path().string();
  fs::create_directories(fs::path(out) / "logs");
  const std::string port_file = (fs::path(out) / "logs" / "server.port").string();
  fs::remove(port_file);

  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  const pid_t server = spawn({bin_dir + "/fusion_server", "--listen", "127.0.0.1:" + std::to_string(port), "--pods",
                              std::to_string(pods), "--port-file", port_file},
                             (fs::path(out) / "logs" / "server.log").string());
  std::string bound;
  for (int i = 0; i < 250 && bound.empty(); ++i) {
    std::ifstream in(port_file);
    std::getline(in, bound);
    if (bound.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    int status;
    if (waitpid(server, &status, WNOHANG) == server) {
      std::fprintf(stderr, "[loop] fusion_server exited at start-up; see %s/logs/server.log\n", out.c_str());
      return 1;
    }
  }
  if (bound.empty()) {
    std::fprintf(stderr, "[loop] fusion_server did not report its port within 5 s\n");
    stop(server, "fusion_server");
    return 1;
  }
  const std::string endpoint = "127.0.0.1:" + bound;
  std::printf("[loop] server on %s, scene %s, %d pods at %s, %.1f fps; writing %s\n", endpoint.c_str(), scene.c_str(),
              pods, size.c_str(), fps, out.c_str());
  std::fflush(stdout);
  std::vector<pid_t> pod_pids;
  for (int i = 0; i < pods; ++i) {
    pod_pids.push_back(spawn({bin_dir + "/capture_node", "--server", endpoint, "--pod-id", std::to_string(i), "--pods",
                              std::to_string(pods), "--size", size, "--fps", std::to_string(fps), "--scene", scene},
                             (fs::path(out) / "logs" / ("pod" + std::to_string(i) + ".log")).string()));
  }
  std::vector<std::string> client_args = {bin_dir + "/render_client", "--server", endpoint, "--out", out, "--frames",
                                         std::to_string(frames), "--size", size, "--mode", mode, "--view", view};
  if (!budget.empty()) {
    client_args.push_back("--budget");
    client_args.push_back(budget);
  }
  const pid_t client = spawn(client_args,
                             (fs::path(out) / "logs" / "client.log").string());
  int client_status = 0;
  bool client_done = false;
  while (!g_interrupted && !client_done) {
    client_done = waitFor(client, 100, &client_status);
  }
  if (!client_done) {
    std::printf("\n[loop] interrupted: stopping the client (it writes its report)\n");
    stop(client, "render_client");
  }
  for (size_t i = 0; i < pod_pids.size(); ++i) stop(pod_pids[i], "capture_node");
  stop(server, "fusion_server");
  const bool ok = client_done ? (WIFEXITED(client_status) && WEXITSTATUS(client_status) == 0) : true;
  if (!ok) {
    // Say why right here: the end of the client's log.
    std::fprintf(stderr, "[loop] render_client failed; the end of %s/logs/client.log:\n", out.c_str());
    std::ifstream log(fs::path(out) / "logs" / "client.log");
    std::vector<std::string> lines;
    for (std::string line; std::getline(log, line);) lines.push_back(line);
    for (size_t i = lines.size() > 15 ? lines.size() - 15 : 0; i < lines.size(); ++i) {
      std::fprintf(stderr, "  %s\n", lines[i].c_str());
    }
  }
  if (ok) {
    std::printf("[loop] all processes stopped; frames in %s/frames, report in %s/report.json, logs in %s/logs\n",
                out.c_str(), out.c_str(), out.c_str());
  } else {
    std::printf("[loop] all processes stopped; logs in %s/logs\n", out.c_str());
  }
  return ok ? 0 : 1;
}
