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

// A flag of the shared table (common/command_line.h) the launcher takes
// and passes on, with its help and range, so it refuses what the process
// would; passed on only when given, so each process keeps its own default
// otherwise.
struct ForwardedSetting {
  const holofuse::SharedFlag* shared;
  std::string value;
};

std::vector<ForwardedSetting> forwardedSettings() {
  std::vector<ForwardedSetting> settings;
  for (const holofuse::SharedFlag& f : holofuse::sharedFlags()) {
    if (f.passed_to != 0) settings.push_back({&f, {}});
  }
  return settings;
}

void addForwarded(CLI::App& app, ForwardedSetting& setting) {
  const unsigned to = setting.shared->passed_to;
  const std::string who = (to & holofuse::kToClient) ? ""
                          : (to & holofuse::kToPods) && (to & holofuse::kToServer)
                              ? " (pods and server)"
                          : (to & holofuse::kToPods) ? " (pods)"
                                                     : " (server)";
  app.add_option(setting.shared->flag, setting.value, setting.shared->description + who)
      ->check(setting.shared->check());
}

// Appends the given settings that go to process (its name for each).
void appendForwarded(const std::vector<ForwardedSetting>& settings, holofuse::LoopProcess process,
                     std::vector<std::string>& args) {
  for (const auto& s : settings) {
    if (s.value.empty() || !(s.shared->passed_to & process)) continue;
    const char* name =
        process == holofuse::kToPods && s.shared->pods_name ? s.shared->pods_name : s.shared->flag;
    args.insert(args.end(), {name, s.value});
  }
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

}  // namespace

int main(int argc, char** argv) {
  int pods = 4, frames = 40, port = 0;
  double fps = 5.0;
  std::string size = "320x240", out = "out/demo", bin_dir, mode = "normal", view = "orbit",
              scene = "clean";
  CLI::App app{"holofuse loop: pods -> fusion server -> render client on localhost"};
  app.add_option("--pods", pods, "camera pods (1..16)")->check(CLI::Range(1, 16));
  app.add_option("--frames", frames, "frames the client renders before everything stops")
      ->check(CLI::Range(1, 1000000));
  app.add_option("--size", size, "pod image and output size WxH");
  app.add_option("--fps", fps, "pod frame rate")->check(CLI::Range(0.5, 120.0));
  app.add_option("--out", out, "output folder");
  app.add_option("--port", port, "server port (0: any free port)")->check(CLI::Range(0, 65535));
  app.add_option("--mode", mode, "blending mode of the client")
      ->check(CLI::IsMember(holofuse::render::blendModeNames()));
  app.add_option("--view", view, "client view: orbit or pod:N");
  app.add_option(
      "--scene", scene,
      "named synthetic scene (its camera count unless --pods): " + holofuse::scene::sceneNames());
  // Passed on only when given, so the pods keep the scene's own otherwise.
  std::optional<uint64_t> seed_value;
  std::optional<double> noise_value;
  app.add_option("--seed", seed_value,
                 "synthetic pods' scene seed (their motion, texture and calibration error)");
  holofuse::addSharedFlag(app, "--noise", noise_value);
  std::string budget;
  app.add_option("--budget", budget,
                 "JSON of per-stage ms budgets for the client's report (flags violations)");
  bool quality = false;
  app.add_flag("--quality", quality,
               "judge every written frame against the synthetic scene's true image from the same "
               "view (PSNR, SSIM "
               "in the report); off by default: the client renders the truth between frames, which "
               "on a small "
               "machine delays the next ones");
  app.add_option("--bin-dir", bin_dir, "folder of the executables (default: next to this one)");
  std::string record, replay, speed = "1";
  std::vector<std::string> dataset_server_args;
  bool record_fused = false, loop = false;
  double hull_error_mm = 0;
  holofuse::addSharedFlag(app, "--hull-error-mm", hull_error_mm);
  std::vector<ForwardedSetting> forwarded = forwardedSettings();
  for (auto& s : forwarded) addForwarded(app, s);
  app.add_option("--record", record,
                 "record what the pods send into this folder (a dataset for --replay)");
  app.add_flag("--record-fused", record_fused,
               "with --record: also record the server's fused meshes and images");
  app.add_option(
      "--replay", replay,
      "replay this dataset folder through the same network path instead of synthetic pods");
  app.add_option(
      "--speed", speed,
      "with --replay: 1 the recorded pace, 2 twice as fast, max as fast as the server accepts");
  app.add_flag("--loop", loop, "with --replay: start over at the end (until --frames or Ctrl-C)");
  HOLOFUSE_PARSE_FLAGS(app, argc, argv)
  // What the processes would refuse is refused here, before any starts.
  unsigned width = 0, height = 0;
  // A replay's pods keep the recorded size: --size is then the client's
  // output alone, which may be larger than a pod's image.
  if (const std::string error =
          holofuse::parseImageSize(size, width, height, replay.empty() ? 4096 : 8192);
      !error.empty()) {
    std::fprintf(stderr, "--size %s\n", error.c_str());
    return 2;
  }
  if (!holofuse::isViewName(view)) {
    std::fprintf(stderr, "--view '%s': expected orbit or pod:N\n", view.c_str());
    return 2;
  }
  if (!replay.empty() && quality) {
    std::fprintf(stderr, "--quality needs a synthetic scene's truth; a --replay has none\n");
    return 2;
  }
  const std::string seed = seed_value ? std::to_string(*seed_value) : "";
  char noise_text[32] = "";
  if (noise_value) std::snprintf(noise_text, sizeof(noise_text), "%.9g", *noise_value);
  const std::string noise = noise_text;
  for (const char* synthetic : {"--seed", "--noise"}) {
    if (!replay.empty() && app.count(synthetic)) {
      std::fprintf(stderr, "%s is a synthetic pod's; a --replay sends the recorded images\n",
                   synthetic);
      return 2;
    }
  }
  holofuse::protocol::Budget checked_budget;
  auto loaded_budget = holofuse::protocol::loadBudgetFlag(budget);
  if (!loaded_budget.isOk()) {
    std::fprintf(stderr, "%s\n", loaded_budget.status().message().c_str());
    return 2;
  }
  checked_budget = *loaded_budget;
  double speed_factor = 1.0;
  if (!holofuse::capture::parseReplaySpeed(speed, speed_factor)) {
    std::fprintf(stderr, "--speed '%s': expected a factor in (0, 1000] or max\n", speed.c_str());
    return 2;
  }
  if (record_fused && record.empty()) {
    std::fprintf(stderr, "--record-fused needs --record DIR\n");
    return 2;
  }
  if (!replay.empty()) {
    // The dataset decides the cameras and the image size.
    auto dataset = holofuse::dataset::Dataset::open(replay);
    if (!dataset.isOk()) {
      std::fprintf(stderr, "--replay: %s\n", dataset.status().message().c_str());
      return 2;
    }
    if (dataset->cameras().empty()) {
      std::fprintf(stderr, "--replay: %s holds no camera\n", replay.c_str());
      return 2;
    }
    pods = static_cast<int>(dataset->cameras().size());
    uint32_t expected_id = 0;
    holofuse::protocol::Calibration calibration;  // camera 0's: the output size
    for (const auto& [id, camera] : dataset->cameras()) {
      if (id != expected_id++ || !camera.calibration) {
        std::fprintf(
            stderr,
            "--replay: %s: cameras must be numbered 0..%d, each with a calibration (camera %u)\n",
            replay.c_str(), pods - 1, id);
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
      size = std::to_string(calibration.width) + "x" + std::to_string(calibration.height);
    if (const auto& metadata = dataset->metadata()) {
      // Carve where the dataset says its subject is, at its resolution.
      char volume[256];
      std::snprintf(volume, sizeof(volume), "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g", metadata->volume_min.x,
                    metadata->volume_min.y, metadata->volume_min.z, metadata->volume_max.x,
                    metadata->volume_max.y, metadata->volume_max.z);
      char voxel[32];
      std::snprintf(voxel, sizeof(voxel), "%.9g", metadata->voxel_size);
      if (metadata->voxel_size > 0) dataset_server_args = {"--volume", volume};
      // A --voxel given here overrides the dataset's.
      if (metadata->voxel_size > 0 && !app.count("--voxel")) {
        dataset_server_args.insert(dataset_server_args.end(), {"--voxel", voxel});
      }
    }
    // A still (one frame of a static scene) repeats so the client can orbit it.
    if (dataset->frameIds() == 1) loop = true;
    if (!app.count("--frames") && !loop) frames = 0;  // the client renders until the replay ends
  }
  const holofuse::scene::ScenePreset* preset = holofuse::scene::findScene(scene);
  if (preset == nullptr) {
    std::fprintf(stderr, "--scene '%s': unknown; valid scenes: %s\n", scene.c_str(),
                 holofuse::scene::sceneNames().c_str());
    return 2;
  }
  if (app.count("--scene") && !app.count("--pods") && replay.empty()) pods = preset->cameras;
  const std::string source =
      replay.empty() ? "scene " + scene : "replay of " + replay + " at speed " + speed;
  namespace fs = std::filesystem;
  if (bin_dir.empty()) bin_dir = fs::canonical("/proc/self/exe").parent_path().string();
  fs::create_directories(fs::path(out) / "logs");
  const std::string port_file = (fs::path(out) / "logs" / "server.port").string();
  fs::remove(port_file);

  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  std::vector<std::string> server_args = {bin_dir + "/fusion_server",
                                          "--listen",
                                          "127.0.0.1:" + std::to_string(port),
                                          "--pods",
                                          std::to_string(pods),
                                          "--port-file",
                                          port_file};
  if (hull_error_mm > 0) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.9g", hull_error_mm);
    server_args.insert(server_args.end(), {"--hull-error-mm", text});
  }
  appendForwarded(forwarded, holofuse::kToServer, server_args);
  if (!record.empty()) {
    server_args.insert(server_args.end(), {"--record", record});
    if (record_fused) server_args.push_back("--record-fused");
  }
  if (!replay.empty()) {
    server_args.insert(server_args.end(), dataset_server_args.begin(), dataset_server_args.end());
    if (speed_factor == 0.0) server_args.push_back("--lossless");
    if (!loop) server_args.push_back("--exit-when-pods-done");
    server_args.insert(server_args.end(), {"--wait-for-clients", "1"});
  }
  const pid_t server = spawn(server_args, (fs::path(out) / "logs" / "server.log").string());
  if (server < 0) return 1;
  std::string bound;
  for (int i = 0; i < 250 && bound.empty(); ++i) {
    std::ifstream in(port_file);
    std::getline(in, bound);
    if (bound.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (holofuse::pollProcess(server)) {
      std::fprintf(stderr, "[loop] fusion_server exited at start-up; see %s/logs/server.log\n",
                   out.c_str());
      return 1;
    }
  }
  if (bound.empty()) {
    std::fprintf(stderr, "[loop] fusion_server did not report its port within 5 s\n");
    stop(server, "fusion_server");
    return 1;
  }
  const std::string endpoint = "127.0.0.1:" + bound;
  std::printf("[loop] server on %s, %s, %d pods at %s, %.1f fps; writing %s\n", endpoint.c_str(),
              source.c_str(), pods, size.c_str(), fps, out.c_str());
  std::fflush(stdout);
  std::vector<pid_t> pod_pids;
  for (int i = 0; i < pods; ++i) {
    std::vector<std::string> pod_args = {bin_dir + "/capture_node", "--server", endpoint,
                                         "--pod-id", std::to_string(i)};
    if (replay.empty()) {
      pod_args.insert(pod_args.end(), {"--pods", std::to_string(pods), "--size", size, "--fps",
                                       std::to_string(fps), "--scene", scene});
      if (!seed.empty()) pod_args.insert(pod_args.end(), {"--seed", seed});
      if (!noise.empty()) pod_args.insert(pod_args.end(), {"--noise", noise});
    } else {
      pod_args.insert(pod_args.end(), {"--replay", replay, "--speed", speed});
      if (loop) pod_args.push_back("--loop");
    }
    // A replay pod sends the recorded bytes as they are: the codec settings
    // reach only the server's images to clients.
    if (replay.empty()) appendForwarded(forwarded, holofuse::kToPods, pod_args);
    pod_pids.push_back(
        spawn(pod_args, (fs::path(out) / "logs" / ("pod" + std::to_string(i) + ".log")).string()));
    if (pod_pids.back() < 0) {
      pod_pids.pop_back();
      for (const pid_t pod : pod_pids) stop(pod, "capture_node");
      stop(server, "fusion_server");
      return 1;
    }
  }
  std::vector<std::string> client_args = {bin_dir + "/render_client",
                                          "--server",
                                          endpoint,
                                          "--out",
                                          out,
                                          "--frames",
                                          std::to_string(frames),
                                          "--size",
                                          size,
                                          "--mode",
                                          mode,
                                          "--view",
                                          view};
  if (replay.empty() && preset->view_jump_degrees != 0) {  // the scene's jump is the user's view's
    client_args.insert(client_args.end(),
                       {"--jump-degrees", std::to_string(preset->view_jump_degrees)});
  }
  if (quality) {  // the judge knows the truth the pods film; the client does not
    std::vector<std::string> judge = {bin_dir + "/holofuse_judge", "--scene", scene, "--fps",
                                      std::to_string(fps)};
    if (!seed.empty()) judge.insert(judge.end(), {"--seed", seed});
    if (!noise.empty()) judge.insert(judge.end(), {"--noise", noise});
    client_args.insert(client_args.end(), {"--judge", shellCommand(judge)});
  }
  appendForwarded(forwarded, holofuse::kToClient, client_args);
  if (!budget.empty()) {
    client_args.push_back("--budget");
    client_args.push_back(budget);
  }
  const bool replay_ends = !replay.empty() && !loop;
  if (replay_ends) client_args.push_back("--exit-when-server-leaves");
  const pid_t client = spawn(client_args, (fs::path(out) / "logs" / "client.log").string());
  if (client < 0) {
    for (const pid_t pod : pod_pids) stop(pod, "capture_node");
    stop(server, "fusion_server");
    return 1;
  }
  int client_exit = 0;
  bool client_done = false, server_done = false, failed = false;
  std::vector<bool> pod_done(pod_pids.size(), false);
  uint64_t waited_after_server_ms = 0;
  while (!g_interrupted && !client_done && !failed) {
    if (const auto code = holofuse::waitProcess(client, 100)) {
      client_exit = *code;
      client_done = true;
      break;
    }
    // A pod that fails (a replay pod that cannot read its dataset) would
    // leave the others waiting for it: stop everything and say why.
    for (size_t i = 0; i < pod_pids.size() && !failed; ++i) {
      if (pod_done[i]) continue;
      const auto code = holofuse::pollProcess(pod_pids[i]);
      if (!code) continue;
      pod_done[i] = true;
      if (*code != 0) {
        std::fprintf(stderr, "\n[loop] capture_node %zu failed; the end of %s/logs/pod%zu.log:\n",
                     i, out.c_str(), i);
        printLogTail(fs::path(out) / "logs" / ("pod" + std::to_string(i) + ".log"));
        failed = true;
      }
    }
    const auto server_code = server_done ? std::nullopt : holofuse::pollProcess(server);
    if (server_code) {
      server_done = true;
      if (!replay_ends || *server_code != 0) {
        std::fprintf(stderr, "\n[loop] fusion_server stopped; the end of %s/logs/server.log:\n",
                     out.c_str());
        printLogTail(fs::path(out) / "logs" / "server.log");
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
    stop(client, "render_client");
  }
  for (size_t i = 0; i < pod_pids.size(); ++i) {
    if (!pod_done[i]) stop(pod_pids[i], "capture_node");
  }
  if (!server_done) stop(server, "fusion_server");
  const bool ok = !failed && (client_done ? client_exit == 0 : true);
  if (!ok && !failed) {
    // Say why right here: the end of the client's log.
    std::fprintf(stderr, "[loop] render_client failed; the end of %s/logs/client.log:\n",
                 out.c_str());
    printLogTail(fs::path(out) / "logs" / "client.log");
  }
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
