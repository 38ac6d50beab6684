// holofuse_loop: starts the whole live loop on localhost as separate
// processes (one fusion_server, N capture_node pods, one render_client),
// relays the client's progress, and stops everything cleanly when the
// client has its frames or on Ctrl-C, leaving no process behind. With
// --netns each process runs in a network namespace of its own, every link
// through an impairing relay (deploy/netns_rig.h): a rig of hosts on one
// machine.
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "base/process.h"
#include "capture_node/replay_pod.h"
#include "common/command_line.h"
#include "dataset/dataset.h"
#include "deploy/netns_rig.h"
#include "deploy/soak.h"
#include "eval/loop_settings.h"
#include "protocol/auth.h"
#include "protocol/messages.h"
#include "protocol/stage_budget.h"
#include "render_client/blend_mode.h"
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
  // (In a rig the program follows ip netns exec's words.)
  options.stdout_to_log = std::none_of(args.begin(), args.end(), [](const std::string& word) {
    return word.find("/render_client") != std::string::npos;
  });
  options.ignore_interrupt = true;
  // A launcher killed outright (a test's time limit, an OOM kill) takes
  // its rig with it rather than leaving it to eat the machine.
  options.die_with_parent = true;
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
  int pods = 4, frames = 40, port = 0, clients = 1;
  // A soak (deploy/soak.h): the loop runs this long, its processes sampled
  // every sample_seconds; 0: an ordinary run that ends with the frames.
  double soak_minutes = 0, sample_seconds = 60, warmup_minutes = 2;
  // What a 2-core machine's client sustains in mode normal (measured by
  // `./holofuse bench loop`); a slower mode renders the newest mesh it can.
  double fps = 15.0;
  std::string size = "320x240", out = "out/demo", bin_dir, mode = "normal", view = "orbit",
              scene = "clean";
  std::string overlap_render = "auto";
  std::string frames_ahead = "2";
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
  // Fresh keys for this run only, one per identity (mode 0600, removed at
  // the end): the loop is authenticated like a rig, no other process can
  // join it, and no pod can be another.
  std::string key_dir;
  const holofuse::scene::ScenePreset* preset = nullptr;
  // A rig on this machine (--netns): a namespace per process, each link
  // impaired by a relay; the server then listens on its namespace's
  // address instead of loopback.
  bool netns = false;
  holofuse::RigLink link;
  std::string listen_host = "127.0.0.1";
  // A rig file (--rig, docs/rig-file.md): its pods and clients, each
  // process reading its part, the launcher's flags given on top.
  std::string rig_file;
  std::optional<holofuse::RigFile> rig;
  std::vector<std::string> given;  // the flags given to the launcher
  std::vector<holofuse::RigLink> pod_links, client_links;
};

bool wasGiven(const LoopPlan& plan, const std::string& flag) {
  return std::find(plan.given.begin(), plan.given.end(), flag) != plan.given.end();
}

// The value a rig file's part gives flag ("" when it gives none).
std::string partValue(const std::vector<holofuse::RigOption>& part, const std::string& flag) {
  for (const auto& option : part)
    if ("--" + option.name == flag) return option.values.front();
  return "";
}

// Whether the launcher passes its value of flag to a process whose rig
// part is part: always without a rig; with one, when the flag was given
// to the launcher (the command line wins) or the part does not set it
// (then the launcher's value is the rig's cameras' or its own default).
bool passes(const LoopPlan& plan, const std::vector<holofuse::RigOption>& part,
            const std::string& flag) {
  return !plan.rig || wasGiven(plan, flag) || partValue(part, flag).empty();
}

// A rig process's part, for passes(); empty without a rig. (readRig
// makes the launcher's pods and clients the rig's, so each has a part.)
std::vector<holofuse::RigOption> podPart(const LoopPlan& plan, int pod) {
  if (!plan.rig) return {};
  auto part = plan.rig->podPart(static_cast<uint32_t>(pod));
  return part.isOk() ? *part : std::vector<holofuse::RigOption>{};
}
std::vector<holofuse::RigOption> clientPart(const LoopPlan& plan, int client) {
  if (!plan.rig) return {};
  auto part = plan.rig->clientPart(
      plan.rig->clients.empty() ? 0 : plan.rig->clients.at(static_cast<size_t>(client)).id);
  return part.isOk() ? *part : std::vector<holofuse::RigOption>{};
}

// With a rig, a setting given to the launcher reaches its process even when
// it equals the default (settingArguments passes only what differs from
// the defaults), so that it overrides the file as a flag does.
template <typename S>
void appendGivenDefaults(std::vector<std::string>& args, const LoopPlan& plan,
                         const std::vector<holofuse::Setting<S>>& table, const S& settings) {
  if (!plan.rig) return;
  for (const auto& setting : table) {
    // (The pods' --codec is the launcher's --image-codec.)
    const std::string given = setting.flag == "--codec" ? "--image-codec" : setting.flag;
    if (!wasGiven(plan, given) || std::find(args.begin(), args.end(), setting.flag) != args.end())
      continue;
    args.insert(args.end(), {setting.flag, setting.get(settings)});
  }
}

// Reads --rig: the pods and clients are the file's, each link its own
// (a --link-* flag sets every link's), and the launcher's values of the
// pods' size, rate, scene, seed and noise are the rig's cameras' where
// the flags do not give them (a pod's own entry stays its own). 0, or the
// exit code after saying what is wrong.
int readRig(LoopPlan& plan) {
  auto rig = holofuse::RigFile::load(plan.rig_file);
  if (!rig.isOk()) {
    std::fprintf(stderr, "--rig: %s\n", rig.status().message().c_str());
    return 2;
  }
  for (const char* flag : {"--pods", "--clients", "--replay"}) {
    if (wasGiven(plan, flag)) {
      std::fprintf(stderr, "%s: the rig file %s names the pods and clients; drop one of them\n",
                   flag, plan.rig_file.c_str());
      return 2;
    }
  }
  // A replay's cameras are its dataset's, which the launcher reads from
  // --replay alone.
  for (const auto& pod : rig->pods) {
    const auto part = rig->podPart(pod.id);
    for (const auto& option : part.isOk() ? *part : std::vector<holofuse::RigOption>{}) {
      if (option.name != "replay") continue;
      std::fprintf(stderr,
                   "--rig: %s: replay: the launcher replays a dataset with --replay, not from a "
                   "rig file\n",
                   option.where.c_str());
      return 2;
    }
  }
  plan.rig = std::move(*rig);
  plan.rig_file = std::filesystem::absolute(plan.rig_file).string();
  plan.rig->path = plan.rig_file;
  plan.pods = static_cast<int>(plan.rig->pods.size());
  plan.clients = std::max<int>(1, static_cast<int>(plan.rig->clients.size()));
  if (plan.clients > 8) {
    std::fprintf(stderr, "--rig: %s names %d clients; the launcher starts at most 8\n",
                 plan.rig_file.c_str(), plan.clients);
    return 2;
  }
  auto linkOf = [&](holofuse::RigLink link) {
    if (wasGiven(plan, "--link-delay-ms")) link.delay_ms = plan.link.delay_ms;
    if (wasGiven(plan, "--link-jitter-ms")) link.jitter_ms = plan.link.jitter_ms;
    if (wasGiven(plan, "--link-rate-mbit")) link.rate_mbit = plan.link.rate_mbit;
    return link;
  };
  plan.link = linkOf(plan.rig->link);
  for (const auto& pod : plan.rig->pods) plan.pod_links.push_back(linkOf(pod.link));
  for (const auto& client : plan.rig->clients) plan.client_links.push_back(linkOf(client.link));
  std::vector<holofuse::RigLink> links = plan.pod_links;
  links.insert(links.end(), plan.client_links.begin(), plan.client_links.end());
  for (size_t i = 0; i < links.size(); ++i) {
    if (links[i].jitter_ms <= links[i].delay_ms) continue;
    const bool pod = i < plan.pod_links.size();
    std::fprintf(
        stderr, "--rig: %s's link: jitter %g ms (%s) is more than its delay %g ms (%s)\n",
        (pod ? "pod " + std::to_string(i) : "client " + std::to_string(i - plan.pod_links.size()))
            .c_str(),
        links[i].jitter_ms,
        wasGiven(plan, "--link-jitter-ms") ? "--link-jitter-ms" : plan.rig_file.c_str(),
        links[i].delay_ms,
        wasGiven(plan, "--link-delay-ms") ? "--link-delay-ms" : plan.rig_file.c_str());
    return 2;
  }
  const bool shaped = std::any_of(links.begin(), links.end(), [](const holofuse::RigLink& link) {
    return link.delay_ms > 0 || link.rate_mbit > 0;
  });
  if (shaped && !plan.netns)
    std::printf("[loop] the rig file's links take effect with --netns (./holofuse rig)\n");
  const auto& cameras = plan.rig->cameras;
  for (auto [flag, value] : {std::pair{"--size", &plan.size},
                             {"--scene", &plan.scene},
                             {"--seed", &plan.seed},
                             {"--noise", &plan.noise}}) {
    if (!wasGiven(plan, flag) && !partValue(cameras, flag).empty())
      *value = partValue(cameras, flag);
  }
  if (!wasGiven(plan, "--fps") && !partValue(cameras, "--fps").empty()) {
    double fps = 0;
    if (const std::string error =
            holofuse::parseNumberIn(partValue(cameras, "--fps"), 0.1, 240, fps);
        !error.empty()) {
      std::fprintf(stderr, "--rig: %s: the cameras' fps: %s\n", plan.rig_file.c_str(),
                   error.c_str());
      return 2;
    }
    plan.fps = fps;
  }
  return 0;
}

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
  app.add_option("--clients", plan.clients,
                 "render clients; with more than one each writes into OUT/client<N>")
      ->check(CLI::Range(1, 8));
  app.add_option("--soak-minutes", plan.soak_minutes,
                 "a soak: run this long (clients render until then), sample every process's "
                 "memory, descriptors and threads, and judge them flat after the warm-up "
                 "(OUT/soak.md, soak.html, soak.json)")
      ->check(CLI::Range(0.0, 10080.0));
  app.add_option("--sample-seconds", plan.sample_seconds, "with --soak-minutes: between samples")
      ->check(CLI::Range(1.0, 3600.0));
  app.add_option("--warmup-minutes", plan.warmup_minutes,
                 "with --soak-minutes: samples before this are not judged")
      ->check(CLI::Range(0.0, 10080.0));
  app.add_option("--size", plan.size, "pod image and output size WxH");
  app.add_option("--fps", plan.fps, "pod frame rate")->check(CLI::Range(0.5, 120.0));
  app.add_option("--out", plan.out, "output folder");
  app.add_option("--port", plan.port, "server port (0: any free port)")
      ->check(CLI::Range(0, 65535));
  app.add_option("--mode", plan.mode, "blending mode of the client")
      ->check(CLI::IsMember(holofuse::render::blendModeNames()));
  app.add_option("--view", plan.view, "client view: orbit or pod:N");
  app.add_option("--overlap-render", plan.overlap_render,
                 "client: on, the next frame decodes while the device renders this one; off, "
                 "each render is waited for; auto, on with a GPU only")
      ->check(CLI::IsMember({"auto", "on", "off"}));
  app.add_option("--frames-ahead", plan.frames_ahead,
                 "client: fused frames it asks the server for ahead of the one rendering; the "
                 "server fuses only what a client asked for (0: every group, each client takes "
                 "them all)")
      ->check(CLI::Range(0, 8));
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
  app.add_flag("--netns", plan.netns,
               "a rig on this machine: the server, each pod and each client in a network "
               "namespace of its own, every link through a relay (needs root)");
  app.add_option("--link-delay-ms", plan.link.delay_ms, "with --netns: each link's one-way delay")
      ->check(CLI::Range(0.0, 10000.0));
  app.add_option("--link-jitter-ms", plan.link.jitter_ms,
                 "with --netns: each link's jitter around its delay (order kept)")
      ->check(CLI::Range(0.0, 10000.0));
  app.add_option("--link-rate-mbit", plan.link.rate_mbit,
                 "with --netns: each link's rate cap each way (0: none)")
      ->check(CLI::Range(0.0, 100000.0));
  app.add_option("--rig", plan.rig_file,
                 "a rig file (YAML, docs/rig-file.md): its pods, clients and links, each "
                 "process reading its part; flags given here override it");
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
  for (const CLI::Option* option : app.get_options())
    if (option->count() > 0) plan.given.push_back(option->get_name());
  if (!plan.rig_file.empty()) {
    if (const int code = readRig(plan); code != 0) return code;
  }
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
  if (plan.soak_minutes > 0 && !plan.replay.empty() && !plan.loop) {
    std::fprintf(stderr, "--soak-minutes needs a loop that does not end: add --loop to --replay\n");
    return 2;
  }
  if (plan.soak_minutes > 0 && plan.warmup_minutes >= plan.soak_minutes) {
    std::fprintf(stderr, "--warmup-minutes %g leaves nothing of a %g-minute soak to judge\n",
                 plan.warmup_minutes, plan.soak_minutes);
    return 2;
  }
  for (const char* link : {"--link-delay-ms", "--link-jitter-ms", "--link-rate-mbit"}) {
    if (!plan.netns && app.count(link)) {
      std::fprintf(stderr, "%s shapes a rig's links: add --netns (./holofuse rig)\n", link);
      return 2;
    }
  }
  if (plan.link.jitter_ms > plan.link.delay_ms) {
    std::fprintf(stderr, "--link-jitter-ms %g is more than the delay %g it varies\n",
                 plan.link.jitter_ms, plan.link.delay_ms);
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
  // (A rig's pods are its file's.)
  if (app.count("--scene") && !app.count("--pods") && plan.replay.empty() && !plan.rig)
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
                                   plan.listen_host + ":" + std::to_string(plan.port),
                                   "--pods",
                                   std::to_string(plan.pods),
                                   "--port-file",
                                   port_file,
                                   "--key-file",
                                   plan.key_dir + "/server.keys"};
  if (plan.rig) append(args, {"--rig", plan.rig_file});
  append(args, holofuse::eval::serverArguments(plan.settings));
  appendGivenDefaults(args, plan, holofuse::fusion::fusionFlags(), plan.settings.fusion);
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
                                   plan.key_dir + "/pod-" + std::to_string(pod) + ".key"};
  if (!plan.replay.empty()) {
    // A replay pod sends the recorded bytes as they are: the codec
    // settings reach only the server's images to clients.
    append(args, {"--replay", plan.replay, "--speed", plan.speed});
    if (plan.loop) args.push_back("--loop");
    return args;
  }
  append(args, {"--pods", std::to_string(plan.pods)});
  const auto part = podPart(plan, pod);
  if (plan.rig) append(args, {"--rig", plan.rig_file});
  for (const auto& [flag, value] : {std::pair<std::string, std::string>{"--size", plan.size},
                                    {"--fps", std::to_string(plan.fps)},
                                    {"--scene", plan.scene},
                                    {"--seed", plan.seed},
                                    {"--noise", plan.noise}}) {
    if (!value.empty() && passes(plan, part, flag)) append(args, {flag, value});
  }
  append(args, holofuse::eval::podArguments(plan.settings));
  appendGivenDefaults(args, plan, holofuse::podEncodingFlags(), plan.settings.pods);
  return args;
}

// Where client `index` writes: OUT itself when it is the only one.
std::string clientOut(const LoopPlan& plan, int index) {
  if (plan.clients == 1) return plan.out;
  return (std::filesystem::path(plan.out) / ("client" + std::to_string(index))).string();
}

std::vector<std::string> clientCommand(const LoopPlan& plan, const std::string& endpoint,
                                       int index) {
  // A soak's clients render until it ends.
  const int frames = plan.soak_minutes > 0 ? 1000000 : plan.frames;
  const uint32_t id = plan.rig && !plan.rig->clients.empty() ? plan.rig->clients.at(index).id : 0;
  std::vector<std::string> args = {plan.bin_dir + "/render_client",
                                   "--server",
                                   endpoint,
                                   "--key-file",
                                   plan.key_dir + "/client-" + std::to_string(id) + ".key",
                                   "--out",
                                   clientOut(plan, index),
                                   "--frames",
                                   std::to_string(frames)};
  if (plan.rig) append(args, {"--rig", plan.rig_file, "--client-id", std::to_string(id)});
  const auto part = clientPart(plan, index);
  for (const auto& [flag, value] : {std::pair<std::string, std::string>{"--size", plan.size},
                                    {"--mode", plan.mode},
                                    {"--view", plan.view},
                                    {"--overlap-render", plan.overlap_render},
                                    {"--frames-ahead", plan.frames_ahead}}) {
    if (passes(plan, part, flag)) append(args, {flag, value});
  }
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
  appendGivenDefaults(args, plan, holofuse::render::renderFlags(), plan.settings.render);
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
  pid_t server = -1;
  std::vector<pid_t> pods, clients;

  void stopAll() {
    for (const pid_t client : clients) stop(client, "render_client");
    for (const pid_t pod : pods) stop(pod, "capture_node");
    stop(server, "fusion_server");
  }
};

// The port the server wrote into port_file, or "" after saying why not.
// It ends early when the server does; the limit is for a server alive but
// stuck, not a slow one (a sanitized build on a busy machine took over 5 s).
std::string awaitServerPort(LoopProcesses& processes, const std::string& port_file,
                            const std::string& out) {
  std::string bound;
  for (int i = 0; i < 3000 && bound.empty(); ++i) {
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
    std::fprintf(stderr, "[loop] fusion_server did not report its port within 60 s\n");
  return bound;
}

// Client i's log, beside the others'.
std::filesystem::path clientLog(const LoopPlan& plan, size_t i) {
  const std::filesystem::path logs = std::filesystem::path(plan.out) / "logs";
  return logs /
         (plan.clients == 1 ? std::string("client.log") : "client" + std::to_string(i) + ".log");
}

// Polls the pods and the server between waits: a pod that fails (a replay
// pod that cannot read its dataset) or a server that stops while it should
// not fails the run, said with the end of its log.
struct Watch {
  std::vector<bool> pod_done;
  bool server_done = false, failed = false;

  void check(const LoopPlan& plan, LoopProcesses& processes) {
    const std::filesystem::path logs = std::filesystem::path(plan.out) / "logs";
    pod_done.resize(processes.pods.size(), false);
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
  }

  // Stops what still runs.
  void stopRest(LoopProcesses& processes, const std::vector<bool>& client_done) {
    for (size_t i = 0; i < processes.clients.size(); ++i)
      if (!client_done[i]) stop(processes.clients[i], "render_client");
    for (size_t i = 0; i < processes.pods.size(); ++i)
      if (!pod_done[i]) stop(processes.pods[i], "capture_node");
    if (!server_done) stop(processes.server, "fusion_server");
  }
};

// Waits for the clients to finish, a process to fail or Ctrl-C, then
// stops what still runs. The launcher's exit code.
int superviseLoop(const LoopPlan& plan, LoopProcesses& processes) {
  const size_t n = processes.clients.size();
  std::vector<int> client_exit(n, 0);
  std::vector<bool> client_done(n, false);
  Watch watch;
  uint64_t waited_after_server_ms = 0;
  auto all_done = [&] {
    return std::all_of(client_done.begin(), client_done.end(), [](bool done) { return done; });
  };
  while (!g_interrupted && !all_done() && !watch.failed) {
    for (size_t i = 0; i < n; ++i) {
      if (client_done[i]) continue;
      if (const auto code = holofuse::waitProcess(processes.clients[i], 100 / n)) {
        client_exit[i] = *code;
        client_done[i] = true;
      }
    }
    watch.check(plan, processes);
    // A replay ends when the server has fused and delivered everything and
    // said goodbye; the clients then finish on their own.
    if (watch.server_done && !watch.failed && (waited_after_server_ms += 100) > 60000) {
      std::fprintf(stderr,
                   "\n[loop] the client did not finish within 60 s of the end of the replay\n");
      watch.failed = true;
    }
  }
  if (!all_done()) {
    std::printf("\n[loop] %s: stopping the client%s (each writes its report)\n",
                watch.failed ? "failed" : "interrupted", n > 1 ? "s" : "");
  }
  watch.stopRest(processes, client_done);
  bool ok = !watch.failed;
  for (size_t i = 0; i < n && !watch.failed; ++i) {
    if (client_done[i] && client_exit[i] != 0) {
      // Say why right here: the end of the client's log.
      std::fprintf(stderr, "[loop] render_client failed; the end of %s:\n",
                   clientLog(plan, i).c_str());
      printLogTail(clientLog(plan, i));
      ok = false;
    }
  }
  const std::string& out = plan.out;
  if (ok) {
    std::printf("[loop] all processes stopped; frames and report.json in %s%s, logs in %s/logs\n",
                out.c_str(), n > 1 ? "/client<N>" : "", out.c_str());
  } else {
    std::printf("[loop] all processes stopped; logs in %s/logs\n", out.c_str());
  }
  return ok ? 0 : 1;
}

// A rig's links as the first client's report measured them, beside what
// they were set to.
void printLinks(const LoopPlan& plan) {
  std::ifstream in(std::filesystem::path(clientOut(plan, 0)) / "report.json");
  const auto report = nlohmann::json::parse(in, nullptr, false);
  if (report.is_discarded() || !report.contains("latency_ms")) {
    std::printf("[rig] no report.json from the client: no link was measured\n");
    return;
  }
  std::printf("[rig] one-way latency per link, p50 / p95, beside what it is set to:\n");
  for (const auto& [link, ms] : report["latency_ms"]["links"].items()) {
    int pod = -1;
    const holofuse::RigLink& set = std::sscanf(link.c_str(), "pod_%d_to_server", &pod) == 1 &&
                                           pod >= 0 && pod < static_cast<int>(plan.pod_links.size())
                                       ? plan.pod_links[pod]
                                   : link == "server_to_client" && !plan.client_links.empty()
                                       ? plan.client_links[0]
                                       : plan.link;
    std::printf("[rig]   %-24s %7.1f / %7.1f ms   (set %g +- %g ms)\n", link.c_str(),
                ms["p50"].get<double>(), ms["p95"].get<double>(), set.delay_ms, set.jitter_ms);
  }
}

// A soak: the loop runs for plan.soak_minutes while every process is
// sampled each plan.sample_seconds, then stops and is judged
// (deploy/soak.h). Ctrl-C ends it early with the samples so far.
int superviseSoak(const LoopPlan& plan, LoopProcesses& processes) {
  holofuse::deploy::SoakReport report;
  std::vector<pid_t> pids = {processes.server};
  report.processes = {"server"};
  for (size_t i = 0; i < processes.pods.size(); ++i) {
    pids.push_back(processes.pods[i]);
    report.processes.push_back("pod " + std::to_string(i));
  }
  for (size_t i = 0; i < processes.clients.size(); ++i) {
    pids.push_back(processes.clients[i]);
    report.processes.push_back("client " + std::to_string(i));
  }
  char settings[256];
  std::snprintf(settings, sizeof(settings),
                "%d pods at %s and %.1f fps, %d clients in mode %s, %g minutes sampled every %g s",
                plan.pods, plan.size.c_str(), plan.fps, plan.clients, plan.mode.c_str(),
                plan.soak_minutes, plan.sample_seconds);
  report.settings = settings;
  report.warmup_minutes = plan.warmup_minutes;
  Watch watch;
  const auto start = std::chrono::steady_clock::now();
  auto minutes = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / 60.0;
  };
  double next_sample = plan.sample_seconds / 60.0;
  while (!g_interrupted && minutes() < plan.soak_minutes + 1e-9) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (minutes() < next_sample) continue;
    next_sample += plan.sample_seconds / 60.0;
    holofuse::deploy::SoakSample sample;
    sample.minute = minutes();
    for (pid_t pid : pids) {
      // A process that ended is gone, not a zombie's numbers.
      const bool ended = holofuse::pollProcess(pid).has_value();
      sample.usage.push_back(ended ? std::nullopt : holofuse::processUsage(pid));
    }
    report.samples.push_back(sample);
    uint64_t pods_kb = 0, clients_kb = 0;
    for (size_t i = 1; i < pids.size(); ++i) {
      const uint64_t kb = sample.usage[i] ? sample.usage[i]->rss_kb : 0;
      (i <= processes.pods.size() ? pods_kb : clients_kb) += kb;
    }
    const auto& server = sample.usage[0];
    std::printf(
        "[soak] minute %.1f of %g: server %.1f MB, %d descriptors, %d threads; pods %.1f "
        "MB in all; clients %.1f MB in all\n",
        sample.minute, plan.soak_minutes, server ? server->rss_kb / 1024.0 : 0.0,
        server ? server->descriptors : 0, server ? server->threads : 0, pods_kb / 1024.0,
        clients_kb / 1024.0);
    std::fflush(stdout);
  }
  report.verdict =
      holofuse::deploy::judgeSoak(report.processes, report.samples, plan.warmup_minutes);
  std::printf("[soak] stopping every process\n");
  processes.stopAll();
  const bool written = holofuse::deploy::writeSoakReport(report, plan.out);
  std::printf("[soak] %s; report in %s/soak.md, soak.html, soak.json\n",
              report.verdict.flat ? "flat after the warm-up" : "NOT flat", plan.out.c_str());
  for (const std::string& problem : report.verdict.problems)
    std::printf("[soak]   %s\n", problem.c_str());
  return report.verdict.flat && written ? 0 : 1;
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
  plan.key_dir = (logs / "keys").string();
  fs::remove_all(plan.key_dir);
  std::vector<uint32_t> client_ids = {0};
  if (plan.rig && !plan.rig->clients.empty()) {
    client_ids.clear();
    for (const auto& client : plan.rig->clients) client_ids.push_back(client.id);
  }
  if (const auto made = holofuse::protocol::KeyRing::writeRig(
          plan.key_dir, static_cast<uint32_t>(plan.pods), client_ids);
      !made.isOk()) {
    std::fprintf(stderr, "[loop] cannot make this run's keys: %s\n",
                 made.status().message().c_str());
    return 1;
  }
  // The keys are this run's only: gone when the launcher returns.
  struct RemoveKeys {
    std::string path;
    ~RemoveKeys() { std::filesystem::remove_all(path); }
  } remove_keys{plan.key_dir};

  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  // A rig: the namespaces and links first; they are gone when this returns,
  // or, should the launcher be killed, when its reaper sees it end.
  std::unique_ptr<holofuse::deploy::NetnsRig> rig;
  if (plan.netns) {
    auto built = holofuse::deploy::NetnsRig::build(
        {plan.pods, plan.clients, plan.link, plan.pod_links, plan.client_links,
         plan.bin_dir + "/holofuse_relay", logs.string()});
    if (!built.isOk()) {
      std::fprintf(stderr, "[rig] cannot build the rig: %s\n", built.status().message().c_str());
      return 1;
    }
    rig = std::move(*built);
    plan.listen_host = rig->serverAddress();
    std::printf("[rig] %s\n", rig->describe().c_str());
  }
  LoopProcesses processes;
  const auto server_command = serverCommand(plan, port_file);
  processes.server =
      spawn(rig ? rig->inServer(server_command) : server_command, (logs / "server.log").string());
  if (processes.server < 0) return 1;
  const std::string bound = awaitServerPort(processes, port_file, plan.out);
  if (bound.empty()) {
    processes.stopAll();
    return 1;
  }
  const std::string endpoint = plan.listen_host + ":" + bound;
  if (rig) {
    if (const holofuse::Status relays = rig->startRelays(bound); !relays.isOk()) {
      std::fprintf(stderr, "[rig] %s\n", relays.message().c_str());
      processes.stopAll();
      return 1;
    }
  }
  const std::string source = plan.replay.empty()
                                 ? "scene " + plan.scene
                                 : "replay of " + plan.replay + " at speed " + plan.speed;
  std::printf("[loop] server on %s, %s, %d pods at %s, %.1f fps; writing %s\n", endpoint.c_str(),
              source.c_str(), plan.pods, plan.size.c_str(), plan.fps, plan.out.c_str());
  std::fflush(stdout);
  for (int i = 0; i < plan.pods; ++i) {
    const auto command = podCommand(plan, i, rig ? rig->podEndpoint(i) : endpoint);
    const pid_t pod = spawn(rig ? rig->inPod(i, command) : command,
                            (logs / ("pod" + std::to_string(i) + ".log")).string());
    if (pod < 0) {
      processes.stopAll();
      return 1;
    }
    processes.pods.push_back(pod);
  }
  for (int i = 0; i < plan.clients; ++i) {
    const auto command = clientCommand(plan, rig ? rig->clientEndpoint(i) : endpoint, i);
    const pid_t client =
        spawn(rig ? rig->inClient(i, command) : command, clientLog(plan, i).string());
    if (client < 0) {
      processes.stopAll();
      return 1;
    }
    processes.clients.push_back(client);
  }
  if (plan.soak_minutes > 0) return superviseSoak(plan, processes);
  const int code = superviseLoop(plan, processes);
  if (rig) {
    printLinks(plan);
    if (const holofuse::Status gone = rig->tearDown(); gone.isOk()) {
      std::printf("[rig] namespaces, links and relays removed\n");
    } else {
      std::fprintf(stderr, "[rig] %s\n", gone.message().c_str());
      return 1;
    }
  }
  return code;
}
