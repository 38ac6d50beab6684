// holofuse_loop: starts the whole live loop on localhost as separate
// processes (one fusion_server, N capture_node pods, one render_client),
// relays the client's progress, and stops everything cleanly when the
// client has its frames or on Ctrl-C, leaving no process behind.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "base/process.h"
#include "capture_node/replay_pod.h"
#include "common/command_line.h"
#include "dataset/dataset.h"
#include "eval/loop_settings.h"
#include "protocol/auth.h"
#include "protocol/messages.h"
#include "render_client/blend_mode.h"
#include "render_client/latency_report.h"
#include "scene/scene_library.h"

namespace {

volatile sig_atomic_t g_interrupted = 0;
void onSignal(int) { g_interrupted = 1; }

// Starts a child of the loop: its output into log_path (the client's
// stdout stays the terminal, for its progress line), Ctrl-C left to the
// launcher, which decides when children stop. -1, said why, when it cannot
// start.
pid_t spawn(const std::vector<std::string>& args, const std::string& log_path) {
  holofuse::SpawnOptions options;
  options.log_path = log_path;
  options.stdout_to_log = args[0].find("render_client") == std::string::npos;
  options.ignore_interrupt = true;
  auto pid = holofuse::spawnProcess(args, options);
  if (!pid.isOk()) {
    std::fprintf(stderr, "[loop] %s\n", pid.status().message().c_str());
    return -1;
  }
  return *pid;
}

// args as one command line for /bin/sh, each word single-quoted, so that
// a folder with spaces or quotes in its name stays one word.
std::string shellCommand(const std::vector<std::string>& args) {
  std::string command;
  for (const std::string& arg : args) {
    if (!command.empty()) command += ' ';
    command += '\'';
    for (const char c : arg) command += c == '\'' ? std::string("'\\''") : std::string(1, c);
    command += '\'';
  }
  return command;
}

// Everything the launcher was asked for, checked before any process
// starts.
struct LoopPlan {
  int pods = 4, frames = 40, port = 0;
  double fps = 5.0;
  std::string size = "320x240", out = "out/demo", bin_dir, mode = "normal", view = "orbit",
              scene = "clean";
  std::string seed, noise;  // passed on only when given: the pods keep the scene's otherwise
  std::string budget;
  bool quality = false;
  std::string record, replay, speed = "1";
  bool record_fused = false, loop = false;
  double speed_factor = 1.0;
  // The pods', the server's and the client's settings; each process gets
  // those that differ from its defaults.
  holofuse::eval::LoopSettings settings;
  std::vector<std::string> dataset_server_args;  // a replay's capture volume and voxel
  // A fresh key for this run only (mode 0600, removed at the end): the
  // loop is authenticated like a rig, and no other process can join it.
  std::string key_file;
  const holofuse::scene::ScenePreset* preset = nullptr;
};

// What the processes would refuse, refused here: 0 and plan filled, or the
// exit code after saying what is wrong.
int readReplay(CLI::App& app, LoopPlan& plan) {
  // The dataset decides the cameras and the image size.
  auto dataset = holofuse::dataset::Dataset::open(plan.replay);
  if (!dataset.isOk()) {
    std::fprintf(stderr, "--replay: %s\n", dataset.status().message().c_str());
    return 2;
  }
  if (dataset->cameras().empty()) {
    std::fprintf(stderr, "--replay: %s holds no camera\n", plan.replay.c_str());
    return 2;
  }
  plan.pods = static_cast<int>(dataset->cameras().size());
  uint32_t expected_id = 0;
  holofuse::protocol::Calibration calibration;  // camera 0's: the output size
  for (const auto& [id, camera] : dataset->cameras()) {
    if (id != expected_id++ || !camera.calibration) {
      std::fprintf(
          stderr,
          "--replay: %s: cameras must be numbered 0..%d, each with a calibration (camera %u)\n",
          plan.replay.c_str(), plan.pods - 1, id);
      return 2;
    }
    // Checked here, so that no replay pod fails after the others started.
    auto decoded = dataset->readCalibration(id);
    if (!decoded.isOk()) {
      std::fprintf(stderr, "--replay: %s\n", decoded.status().message().c_str());
      return 2;
    }
    if (id == 0) calibration = *decoded;
  }
  if (!app.count("--size"))
    plan.size = std::to_string(calibration.width) + "x" + std::to_string(calibration.height);
  if (const auto& metadata = dataset->metadata(); metadata && metadata->voxel_size > 0) {
    // Carve where the dataset says its subject is, at its resolution.
    char volume[256];
    std::snprintf(volume, sizeof(volume), "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g", metadata->volume_min.x,
                  metadata->volume_min.y, metadata->volume_min.z, metadata->volume_max.x,
                  metadata->volume_max.y, metadata->volume_max.z);
    plan.dataset_server_args = {"--volume", volume};
    // A --voxel given here overrides the dataset's.
    if (!app.count("--voxel")) {
      plan.dataset_server_args.insert(plan.dataset_server_args.end(),
                                      {"--voxel", holofuse::formatNumber(metadata->voxel_size)});
    }
  }
  // A still (one frame of a static scene) repeats so the client can orbit it.
  if (dataset->frameIds() == 1) plan.loop = true;
  if (!app.count("--frames") && !plan.loop) plan.frames = 0;  // until the replay ends
  return 0;
}

// Parses and checks the flags: nullopt and plan filled, or the exit code
// (0 after --help).
std::optional<int> parseLoopFlags(int argc, char** argv, LoopPlan& plan) {
  CLI::App app{"holofuse loop: pods -> fusion server -> render client on localhost"};
  app.add_option("--pods", plan.pods, "camera pods (1..128)")
      ->check(CLI::Range(1, static_cast<int>(holofuse::protocol::kMaxCameras)));
  app.add_option("--frames", plan.frames, "frames the client renders before everything stops")
      ->check(CLI::Range(1, 1000000));
  app.add_option("--size", plan.size, "pod image and output size WxH");
  app.add_option("--fps", plan.fps, "pod frame rate")->check(CLI::Range(0.5, 120.0));
  app.add_option("--out", plan.out, "output folder");
  app.add_option("--port", plan.port, "server port (0: any free port)")
      ->check(CLI::Range(0, 65535));
  app.add_option("--mode", plan.mode, "blending mode of the client")
      ->check(CLI::IsMember(holofuse::render::blendModeNames()));
  app.add_option("--view", plan.view, "client view: orbit or pod:N");
  app.add_option(
      "--scene", plan.scene,
      "named synthetic scene (its camera count unless --pods): " + holofuse::scene::sceneNames());
  std::optional<uint64_t> seed;
  std::optional<double> noise;
  app.add_option("--seed", seed,
                 "synthetic pods' scene seed (their motion, texture and calibration error)");
  app.add_option("--noise", noise, holofuse::scene::kNoiseHelp)
      ->check(CLI::Range(0.0, holofuse::scene::kMaxNoise));
  app.add_option("--budget", plan.budget,
                 "JSON of per-stage ms budgets for the client's report (flags violations)");
  app.add_flag("--quality", plan.quality,
               "judge every written frame against the synthetic scene's true image from the same "
               "view (PSNR, SSIM in the report); off by default: the client renders the truth "
               "between frames, which on a small machine delays the next ones");
  app.add_option("--bin-dir", plan.bin_dir,
                 "folder of the executables (default: next to this one)");
  // Each process's settings, with its help and range, so that the launcher
  // refuses what the process would.
  std::vector<holofuse::Setting<holofuse::eval::LoopSettings>> settings =
      holofuse::eval::loopFlags();
  for (auto& setting : settings) {
    const std::string takers = holofuse::eval::loopFlagTakers(setting.flag);
    if (takers != "client") setting.help += " (" + takers + ")";
  }
  const holofuse::SettingFlags<holofuse::eval::LoopSettings> setting_flags(app, settings);
  app.add_option("--record", plan.record,
                 "record what the pods send into this folder (a dataset for --replay)");
  app.add_flag("--record-fused", plan.record_fused,
               "with --record: also record the server's fused meshes and images");
  app.add_option(
      "--replay", plan.replay,
      "replay this dataset folder through the same network path instead of synthetic pods");
  app.add_option(
      "--speed", plan.speed,
      "with --replay: 1 the recorded pace, 2 twice as fast, max as fast as the server accepts");
  app.add_flag("--loop", plan.loop,
               "with --replay: start over at the end (until --frames or Ctrl-C)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  setting_flags.apply(plan.settings);
  unsigned width = 0, height = 0;
  // A replay's pods keep the recorded size: --size is then the client's
  // output alone, which may be larger than a pod's image.
  if (const std::string error =
          holofuse::parseImageSize(plan.size, width, height, plan.replay.empty() ? 4096 : 8192);
      !error.empty()) {
    std::fprintf(stderr, "--size %s\n", error.c_str());
    return 2;
  }
  if (!holofuse::isViewName(plan.view)) {
    std::fprintf(stderr, "--view '%s': expected orbit or pod:N\n", plan.view.c_str());
    return 2;
  }
  if (!plan.replay.empty() && plan.quality) {
    std::fprintf(stderr, "--quality needs a synthetic scene's truth; a --replay has none\n");
    return 2;
  }
  if (seed) plan.seed = std::to_string(*seed);
  if (noise) plan.noise = holofuse::formatNumber(*noise);
  for (const char* synthetic : {"--seed", "--noise"}) {
    if (!plan.replay.empty() && app.count(synthetic)) {
      std::fprintf(stderr, "%s is a synthetic pod's; a --replay sends the recorded images\n",
                   synthetic);
      return 2;
    }
  }
  if (auto budget = holofuse::protocol::loadBudgetFlag(plan.budget); !budget.isOk()) {
    std::fprintf(stderr, "%s\n", budget.status().message().c_str());
    return 2;
  }
  if (!holofuse::capture::parseReplaySpeed(plan.speed, plan.speed_factor)) {
    std::fprintf(stderr, "--speed '%s': expected a factor in (0, 1000] or max\n",
                 plan.speed.c_str());
    return 2;
  }
  if (plan.record_fused && plan.record.empty()) {
    std::fprintf(stderr, "--record-fused needs --record DIR\n");
    return 2;
  }
  if (!plan.replay.empty()) {
    if (const int code = readReplay(app, plan); code != 0) return code;
  }
  plan.preset = holofuse::scene::findScene(plan.scene);
  if (plan.preset == nullptr) {
    std::fprintf(stderr, "--scene '%s': unknown; valid scenes: %s\n", plan.scene.c_str(),
                 holofuse::scene::sceneNames().c_str());
    return 2;
  }
  if (app.count("--scene") && !app.count("--pods") && plan.replay.empty())
    plan.pods = plan.preset->cameras;
  if (plan.bin_dir.empty())
    plan.bin_dir = std::filesystem::canonical("/proc/self/exe").parent_path().string();
  return std::nullopt;
}

void append(std::vector<std::string>& args, const std::vector<std::string>& more) {
  args.insert(args.end(), more.begin(), more.end());
}

// A replay that is not looped ends by itself: the server leaves when its
// pods are done, and the client finishes after it.
bool replayEnds(const LoopPlan& plan) { return !plan.replay.empty() && !plan.loop; }

std::vector<std::string> serverCommand(const LoopPlan& plan, const std::string& port_file) {
  std::vector<std::string> args = {plan.bin_dir + "/fusion_server",
                                   "--listen",
                                   "127.0.0.1:" + std::to_string(plan.port),
                                   "--pods",
                                   std::to_string(plan.pods),
                                   "--port-file",
                                   port_file,
                                   "--key-file",
                                   plan.key_file};
  append(args, holofuse::eval::serverArguments(plan.settings));
  if (!plan.record.empty()) {
    append(args, {"--record", plan.record});
    if (plan.record_fused) args.push_back("--record-fused");
  }
  if (!plan.replay.empty()) {
    append(args, plan.dataset_server_args);
    if (plan.speed_factor == 0.0) args.push_back("--lossless");
    if (!plan.loop) args.push_back("--exit-when-pods-done");
    append(args, {"--wait-for-clients", "1"});
  }
  return args;
}

std::vector<std::string> podCommand(const LoopPlan& plan, int pod, const std::string& endpoint) {
  std::vector<std::string> args = {plan.bin_dir + "/capture_node",
                                   "--server",
                                   endpoint,
                                   "--pod-id",
                                   std::to_string(pod),
                                   "--key-file",
                                   plan.key_file};
  if (!plan.replay.empty()) {
    // A replay pod sends the recorded bytes as they are: the codec
    // settings reach only the server's images to clients.
    append(args, {"--replay", plan.replay, "--speed", plan.speed});
    if (plan.loop) args.push_back("--loop");
    return args;
  }
  append(args, {"--pods", std::to_string(plan.pods), "--size", plan.size, "--fps",
                std::to_string(plan.fps), "--scene", plan.scene});
  if (!plan.seed.empty()) append(args, {"--seed", plan.seed});
  if (!plan.noise.empty()) append(args, {"--noise", plan.noise});
  append(args, holofuse::eval::podArguments(plan.settings));
  return args;
}

std::vector<std::string> clientCommand(const LoopPlan& plan, const std::string& endpoint) {
  std::vector<std::string> args = {plan.bin_dir + "/render_client",
                                   "--server",
                                   endpoint,
                                   "--key-file",
                                   plan.key_file,
                                   "--out",
                                   plan.out,
                                   "--frames",
                                   std::to_string(plan.frames),
                                   "--size",
                                   plan.size,
                                   "--mode",
                                   plan.mode,
                                   "--view",
                                   plan.view};
  if (plan.replay.empty() && plan.preset->view_jump_degrees != 0) {
    // The scene's jump is the user's view's.
    append(args, {"--jump-degrees", std::to_string(plan.preset->view_jump_degrees)});
  }
  if (plan.quality) {  // the judge knows the truth the pods film; the client does not
    std::vector<std::string> judge = {plan.bin_dir + "/holofuse_judge", "--scene", plan.scene,
                                      "--fps", std::to_string(plan.fps)};
    if (!plan.seed.empty()) append(judge, {"--seed", plan.seed});
    if (!plan.noise.empty()) append(judge, {"--noise", plan.noise});
    append(args, {"--judge", shellCommand(judge)});
  }
  append(args, holofuse::eval::clientArguments(plan.settings));
  if (!plan.budget.empty()) append(args, {"--budget", plan.budget});
  if (replayEnds(plan)) args.push_back("--exit-when-server-leaves");
  return args;
}

void stop(pid_t pid, const char* what) {
  if (pid <= 0) return;
  if (holofuse::stopProcess(pid, 3000).killed) {
    std::fprintf(stderr, "[loop] %s (pid %d) ignored SIGTERM for 3 s; killed it\n", what, pid);
  }
}

// The last lines of a child's log, where a failure is explained.
void printLogTail(const std::filesystem::path& path) {
  std::ifstream log(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(log, line);) lines.push_back(line);
  for (size_t i = lines.size() > 15 ? lines.size() - 15 : 0; i < lines.size(); ++i) {
    std::fprintf(stderr, "  %s\n", lines[i].c_str());
  }
}

// The running loop's processes.
struct LoopProcesses {
  pid_t server = -1, client = -1;
  std::vector<pid_t> pods;

  void stopAll() {
    stop(client, "render_client");
    for (const pid_t pod : pods) stop(pod, "capture_node");
    stop(server, "fusion_server");
  }
};

// The port the server wrote into port_file, or "" after saying why not.
std::string awaitServerPort(LoopProcesses& processes, const std::string& port_file,
                            const std::string& out) {
  std::string bound;
  for (int i = 0; i < 250 && bound.empty(); ++i) {
    std::ifstream in(port_file);
    std::getline(in, bound);
    if (bound.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (holofuse::pollProcess(processes.server)) {
      processes.server = -1;  // gone already
      std::fprintf(stderr, "[loop] fusion_server exited at start-up; see %s/logs/server.log\n",
                   out.c_str());
      return "";
    }
  }
  if (bound.empty())
    std::fprintf(stderr, "[loop] fusion_server did not report its port within 5 s\n");
  return bound;
}

// Waits for the client to finish, a process to fail or Ctrl-C, then stops
// what still runs. The launcher's exit code.
int superviseLoop(const LoopPlan& plan, LoopProcesses& processes) {
  namespace fs = std::filesystem;
  const fs::path logs = fs::path(plan.out) / "logs";
  int client_exit = 0;
  bool client_done = false, server_done = false, failed = false;
  std::vector<bool> pod_done(processes.pods.size(), false);
  uint64_t waited_after_server_ms = 0;
  while (!g_interrupted && !client_done && !failed) {
    if (const auto code = holofuse::waitProcess(processes.client, 100)) {
      client_exit = *code;
      client_done = true;
      break;
    }
    // A pod that fails (a replay pod that cannot read its dataset) would
    // leave the others waiting for it: stop everything and say why.
    for (size_t i = 0; i < processes.pods.size() && !failed; ++i) {
      if (pod_done[i]) continue;
      const auto code = holofuse::pollProcess(processes.pods[i]);
      if (!code) continue;
      pod_done[i] = true;
      if (*code != 0) {
        std::fprintf(stderr, "\n[loop] capture_node %zu failed; the end of %s/pod%zu.log:\n", i,
                     logs.c_str(), i);
        printLogTail(logs / ("pod" + std::to_string(i) + ".log"));
        failed = true;
      }
    }
    const auto server_code = server_done ? std::nullopt : holofuse::pollProcess(processes.server);
    if (server_code) {
      server_done = true;
      if (!replayEnds(plan) || *server_code != 0) {
        std::fprintf(stderr, "\n[loop] fusion_server stopped; the end of %s/server.log:\n",
                     logs.c_str());
        printLogTail(logs / "server.log");
        failed = true;
      }
    }
    // A replay ends when the server has fused and delivered everything and
    // said goodbye; the client then finishes on its own.
    if (server_done && !failed && (waited_after_server_ms += 100) > 60000) {
      std::fprintf(stderr,
                   "\n[loop] the client did not finish within 60 s of the end of the replay\n");
      failed = true;
    }
  }
  if (!client_done) {
    std::printf("\n[loop] %s: stopping the client (it writes its report)\n",
                failed ? "failed" : "interrupted");
    stop(processes.client, "render_client");
  }
  for (size_t i = 0; i < processes.pods.size(); ++i) {
    if (!pod_done[i]) stop(processes.pods[i], "capture_node");
  }
  if (!server_done) stop(processes.server, "fusion_server");
  const bool ok = !failed && (client_done ? client_exit == 0 : true);
  if (!ok && !failed) {
    // Say why right here: the end of the client's log.
    std::fprintf(stderr, "[loop] render_client failed; the end of %s/client.log:\n", logs.c_str());
    printLogTail(logs / "client.log");
  }
  const std::string& out = plan.out;
  if (ok) {
    std::printf(
        "[loop] all processes stopped; frames in %s/frames, report in %s/report.json, logs in "
        "%s/logs\n",
        out.c_str(), out.c_str(), out.c_str());
  } else {
    std::printf("[loop] all processes stopped; logs in %s/logs\n", out.c_str());
  }
  return ok ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  LoopPlan plan;
  if (const auto code = parseLoopFlags(argc, argv, plan)) return *code;
  namespace fs = std::filesystem;
  const fs::path logs = fs::path(plan.out) / "logs";
  fs::create_directories(logs);
  const std::string port_file = (logs / "server.port").string();
  fs::remove(port_file);
  plan.key_file = (logs / "loop.key").string();
  fs::remove(plan.key_file);
  if (const holofuse::Status made = holofuse::protocol::KeyRing::writeNew(plan.key_file);
      !made.isOk()) {
    std::fprintf(stderr, "[loop] cannot make this run's key: %s\n", made.message().c_str());
    return 1;
  }
  // The key is this run's only: gone when the launcher returns.
  struct RemoveKey {
    std::string path;
    ~RemoveKey() { std::filesystem::remove(path); }
  } remove_key{plan.key_file};

  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  LoopProcesses processes;
  processes.server = spawn(serverCommand(plan, port_file), (logs / "server.log").string());
  if (processes.server < 0) return 1;
  const std::string bound = awaitServerPort(processes, port_file, plan.out);
  if (bound.empty()) {
    processes.stopAll();
    return 1;
  }
  const std::string endpoint = "127.0.0.1:" + bound;
  const std::string source = plan.replay.empty()
                                 ? "scene " + plan.scene
                                 : "replay of " + plan.replay + " at speed " + plan.speed;
  std::printf("[loop] server on %s, %s, %d pods at %s, %.1f fps; writing %s\n", endpoint.c_str(),
              source.c_str(), plan.pods, plan.size.c_str(), plan.fps, plan.out.c_str());
  std::fflush(stdout);
  for (int i = 0; i < plan.pods; ++i) {
    const pid_t pod = spawn(podCommand(plan, i, endpoint),
                            (logs / ("pod" + std::to_string(i) + ".log")).string());
    if (pod < 0) {
      processes.stopAll();
      return 1;
    }
    processes.pods.push_back(pod);
  }
  processes.client = spawn(clientCommand(plan, endpoint), (logs / "client.log").string());
  if (processes.client < 0) {
    processes.stopAll();
    return 1;
  }
  return superviseLoop(plan, processes);
}
