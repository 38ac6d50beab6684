#include "deploy/loop_plan.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "capture_node/replay_pod.h"
#include "config/command_line.h"
#include "dataset/dataset.h"
#include "protocol/messages.h"
#include "protocol/stage_budget.h"
#include "render_client/blend_mode.h"

namespace holofuse::deploy {
namespace {

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
  plan.shape.pods = static_cast<int>(plan.rig->pods.size());
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
  if (!wasGiven(plan, "--size") && !partValue(cameras, "--size").empty())
    plan.size = partValue(cameras, "--size");
  for (const auto& setting : holofuse::scene::sceneFlags()) {
    const std::string value = partValue(cameras, setting.flag);
    if (wasGiven(plan, setting.flag) || value.empty()) continue;
    if (const std::string error = setting.set(plan.scene, value); !error.empty()) {
      std::fprintf(stderr, "--rig: %s: the cameras' %s: %s\n", plan.rig_file.c_str(),
                   setting.flag.c_str(), error.c_str());
      return 2;
    }
  }
  if (const std::string fps = partValue(cameras, "--fps");
      !wasGiven(plan, "--fps") && !fps.empty()) {
    const auto* setting = holofuse::findSetting(holofuse::rigShapeFlags(), "--fps");
    if (const std::string error = setting->set(plan.shape, fps); !error.empty()) {
      std::fprintf(stderr, "--rig: %s: the cameras' fps: %s\n", plan.rig_file.c_str(),
                   error.c_str());
      return 2;
    }
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
  plan.shape.pods = static_cast<int>(dataset->cameras().size());
  uint32_t expected_id = 0;
  holofuse::protocol::Calibration calibration;  // camera 0's: the output size
  for (const auto& [id, camera] : dataset->cameras()) {
    if (id != expected_id++ || !camera.calibration) {
      std::fprintf(
          stderr,
          "--replay: %s: cameras must be numbered 0..%d, each with a calibration (camera %u)\n",
          plan.replay.c_str(), plan.shape.pods - 1, id);
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
  plan.replay_frames = dataset->frameIds();
  if (!app.count("--frames") && !plan.loop) plan.frames = 0;  // until the replay ends
  return 0;
}

void append(std::vector<std::string>& args, const std::vector<std::string>& more) {
  args.insert(args.end(), more.begin(), more.end());
}

// settings forwarded through the table its process reads them with: every
// setting that holds a value, where the process's rig part lets it pass.
template <typename S>
void appendSettings(std::vector<std::string>& args, const LoopPlan& plan,
                    const std::vector<holofuse::RigOption>& part,
                    const std::vector<holofuse::Setting<S>>& table, const S& settings) {
  for (const auto& setting : table) {
    const std::string value = setting.get(settings);
    if (!value.empty() && passes(plan, part, setting.flag)) append(args, {setting.flag, value});
  }
}

// The launcher's own flags: the run, its rig and its budget; what it
// records or replays.
void addRunOptions(CLI::App& app, LoopPlan& plan) {
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
  app.add_flag("--churn", plan.churn,
               "with --soak-minutes: client sessions join and leave all through the soak (half "
               "say bye after 8 frames, half are killed after 6 s), and every fifth session a "
               "pod restarts (cleanly and with SIGKILL in turn); in a rig (--netns) every tenth "
               "session also cuts pod 0's link for 5 s");
  app.add_option("--churn-seconds", plan.churn_seconds,
                 "with --churn: between one session's start and the next's")
      ->check(CLI::Range(0.5, 3600.0));
  app.add_flag("--profile", plan.profile,
               "with --soak-minutes: trace the server's heap with heaptrack and name the "
               "allocation sites whose held memory grew from the warm-up's end to the last "
               "sample (OUT/profile/server-growth.txt and the soak report); the server runs "
               "slower, and its memory includes heaptrack's own");
  app.add_option("--sample-seconds", plan.sample_seconds, "with --soak-minutes: between samples")
      ->check(CLI::Range(1.0, 3600.0));
  app.add_option("--warmup-minutes", plan.warmup_minutes,
                 "with --soak-minutes: samples before this are not judged")
      ->check(CLI::Range(0.0, 10080.0));
  app.add_option("--size", plan.size, "pod image and output size WxH");
  app.add_option("--out", plan.out, "output folder");
  app.add_option("--port", plan.port, "server port (0: any free port)")
      ->check(CLI::Range(0, 65535));
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
}

void addRecordingOptions(CLI::App& app, LoopPlan& plan) {
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
}

// The flags together, checked by name once parsed: 0 when the plan holds,
// else the exit code (the reason said).
int checkPlan(CLI::App& app, LoopPlan& plan) {
  unsigned width = 0, height = 0;
  // A replay's pods keep the recorded size: --size is then the client's
  // output alone, which may be larger than a pod's image.
  if (const std::string error =
          holofuse::parseImageSize(plan.size, width, height, plan.replay.empty() ? 4096 : 8192);
      !error.empty()) {
    std::fprintf(stderr, "--size %s\n", error.c_str());
    return 2;
  }
  if (!plan.replay.empty() && plan.quality) {
    std::fprintf(stderr, "--quality needs a synthetic scene's truth; a --replay has none\n");
    return 2;
  }
  for (const char* synthetic : {"--seed", "--noise"}) {
    if (!plan.replay.empty() && app.count(synthetic)) {
      std::fprintf(stderr, "%s is a synthetic pod's; a --replay sends the recorded images\n",
                   synthetic);
      return 2;
    }
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
  if (plan.churn && plan.soak_minutes <= 0) {
    std::fprintf(stderr, "--churn needs --soak-minutes\n");
    return 2;
  }
  if (plan.profile && plan.soak_minutes <= 0) {
    std::fprintf(stderr, "--profile needs --soak-minutes\n");
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
  // (A rig's pods are its file's.)
  if (app.count("--scene") && !app.count("--pods") && plan.replay.empty() && !plan.rig)
    plan.shape.pods = plan.scene.preset().cameras;
  if (plan.bin_dir.empty())
    plan.bin_dir = std::filesystem::canonical("/proc/self/exe").parent_path().string();
  return 0;
}

}  // namespace

// Parses and checks the flags: nullopt and plan filled, or the exit code
// (0 after --help).
std::optional<int> parseLoopFlags(int argc, char** argv, LoopPlan& plan) {
  CLI::App app{"holofuse loop: pods -> fusion server -> render client on localhost"};
  addRunOptions(app, plan);
  // The pods' scene and the client's run, from their own tables.
  auto scene_settings = holofuse::scene::sceneFlags();
  scene_settings.front().help += " (its camera count unless --pods)";
  const holofuse::SettingFlags<holofuse::scene::SceneChoice> scene_flags(app, scene_settings);
  const holofuse::SettingFlags<holofuse::render::ClientRunSettings> client_flags(
      app, holofuse::render::clientRunFlags());
  const holofuse::SettingFlags<holofuse::RigShape> shape_flags(app, holofuse::rigShapeFlags());
  // Each process's settings, with its help and range, so that the launcher
  // refuses what the process would.
  std::vector<holofuse::Setting<holofuse::eval::LoopSettings>> settings =
      holofuse::eval::loopFlags();
  for (auto& setting : settings) {
    const std::string takers = holofuse::eval::loopFlagTakers(setting.flag);
    if (takers != "client") setting.help += " (" + takers + ")";
  }
  const holofuse::SettingFlags<holofuse::eval::LoopSettings> setting_flags(app, settings);
  addRecordingOptions(app, plan);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return exitOnFlagError(app, e);
  }
  setting_flags.apply(plan.settings);
  scene_flags.apply(plan.scene);
  client_flags.apply(plan.client);
  shape_flags.apply(plan.shape);
  for (const CLI::Option* option : app.get_options())
    if (option->count() > 0) plan.given.push_back(option->get_name());
  if (!plan.rig_file.empty()) {
    if (const int code = readRig(plan); code != 0) return code;
  }
  if (const int code = checkPlan(app, plan); code != 0) return code;
  return std::nullopt;
}

bool replayEnds(const LoopPlan& plan) { return !plan.replay.empty() && !plan.loop; }

std::vector<std::string> serverCommand(const LoopPlan& plan, const std::string& port_file) {
  std::vector<std::string> args = {plan.bin_dir + "/fusion_server",
                                   "--listen",
                                   plan.listen_host + ":" + std::to_string(plan.port),
                                   "--pods",
                                   std::to_string(plan.shape.pods),
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
  append(args, {"--pods", std::to_string(plan.shape.pods)});
  const auto part = podPart(plan, pod);
  if (plan.rig) append(args, {"--rig", plan.rig_file});
  for (const auto& [flag, value] : {std::pair<std::string, std::string>{"--size", plan.size},
                                    {"--fps", holofuse::formatNumber(plan.shape.fps)}}) {
    if (passes(plan, part, flag)) append(args, {flag, value});
  }
  appendSettings(args, plan, part, holofuse::scene::sceneFlags(), plan.scene);
  append(args, holofuse::eval::podArguments(plan.settings));
  appendGivenDefaults(args, plan, holofuse::podEncodingFlags(), plan.settings.pods);
  return args;
}

std::string clientOut(const LoopPlan& plan, int index) {
  if (plan.clients == 1) return plan.out;
  return (std::filesystem::path(plan.out) / ("client" + std::to_string(index))).string();
}

std::vector<std::string> clientCommand(const LoopPlan& plan, const std::string& endpoint,
                                       int index) {
  // A soak's clients render until it stops them (0: until signalled), so
  // their progress lines count frames without a made-up total and ETA.
  const int frames = plan.soak_minutes > 0 ? 0 : plan.frames;
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
  if (passes(plan, part, "--size")) append(args, {"--size", plan.size});
  appendSettings(args, plan, part, holofuse::render::clientRunFlags(), plan.client);
  if (plan.clients > 1) {
    // Each client records its layers' video into a folder of its own, as
    // it writes its pictures (else one's files would overwrite another's).
    const auto flag = std::find(args.begin(), args.end(), "--record-layers");
    if (flag != args.end() && flag + 1 != args.end())
      *(flag + 1) =
          (std::filesystem::path(*(flag + 1)) / ("client" + std::to_string(index))).string();
  }
  const double jump = plan.scene.preset().view_jump_degrees;
  if (plan.replay.empty() && jump != 0) {
    // The scene's jump is the user's view's.
    append(args, {"--jump-degrees", std::to_string(jump)});
  }
  if (plan.quality) {  // the judge knows the truth the pods film; the client does not
    std::vector<std::string> judge = {plan.bin_dir + "/holofuse_judge"};
    appendSettings(judge, plan, {}, holofuse::pickSettings(holofuse::rigShapeFlags(), {"--fps"}),
                   plan.shape);
    appendSettings(judge, plan, {}, holofuse::scene::sceneFlags(), plan.scene);
    append(args, {"--judge", shellCommand(judge)});
  }
  append(args, holofuse::eval::clientArguments(plan.settings));
  appendGivenDefaults(args, plan, holofuse::render::renderFlags(), plan.settings.render);
  if (replayEnds(plan)) {
    args.push_back("--exit-when-server-leaves");
    // The progress line counts against the dataset's frames.
    if (frames == 0) append(args, {"--frames-expected", std::to_string(plan.replay_frames)});
  }
  return args;
}

}  // namespace holofuse::deploy
