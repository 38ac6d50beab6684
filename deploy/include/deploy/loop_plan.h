// The live loop's launcher, its plan: every flag holofuse_loop takes,
// checked before any process starts (parseLoopFlags), and the command line
// of each process it starts, with the flags that process takes.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "config/rig_file.h"
#include "config/rig_shape.h"
#include "eval/loop_settings.h"
#include "render_client/render_settings.h"
#include "scene/scene_library.h"

namespace holofuse::deploy {

// Everything the launcher was asked for, checked before any process
// starts.
struct LoopPlan {
  int frames = 40, port = 0, clients = 1;
  // A soak (deploy/soak.h): the loop runs this long, its processes sampled
  // every sample_seconds; 0: an ordinary run that ends with the frames.
  double soak_minutes = 0, sample_seconds = 10, warmup_minutes = 2;
  // A churning soak: a client session joins every churn_seconds (half
  // leave saying bye after 8 frames, half are killed mid-frame after 6 s)
  // and every fifth one a pod restarts (cleanly and with SIGKILL in turn).
  bool churn = false;
  double churn_seconds = 4;
  // A soak's server traced by heaptrack (deploy/heap_profile.h): the
  // allocation sites that grew after the warm-up, named in the report.
  bool profile = false;
  // The pods and their rate (the pods' own table, forwarded), at 15 fps:
  // what a 2-core machine's client sustains in mode normal (measured by
  // `./holofuse bench loop`); a slower mode renders the newest mesh it can.
  RigShape shape{4, 15.0};
  std::string size = "320x240", out = "out/demo", bin_dir;
  // The pods' scene (to the pods and the judge) and each client's run
  // settings, bound from the pods' and the client's own flag tables and
  // forwarded through them.
  scene::SceneChoice scene;
  render::ClientRunSettings client;
  bool quality = false;
  std::string record, replay, speed = "1";
  bool record_fused = false, loop = false;
  double speed_factor = 1.0;
  // The pods', the server's and the client's settings; each process gets
  // those that differ from its defaults.
  eval::LoopSettings settings;
  std::vector<std::string> dataset_server_args;  // a replay's capture volume and voxel
  size_t replay_frames = 0;                      // the replayed dataset's frames
  // Fresh keys for this run only, one per identity (mode 0600, removed at
  // the end): the loop is authenticated like a rig, no other process can
  // join it, and no pod can be another.
  std::string key_dir;
  // A rig on this machine (--netns): a namespace per process, each link
  // impaired by a relay; the server then listens on its namespace's
  // address instead of loopback.
  bool netns = false;
  RigLink link;
  std::string listen_host = "127.0.0.1";
  // A rig file (--rig, docs/rig-file.md): its pods and clients, each
  // process reading its part, the launcher's flags given on top.
  std::string rig_file;
  std::optional<RigFile> rig;
  std::vector<std::string> given;  // the flags given to the launcher
  std::vector<RigLink> pod_links, client_links;
};

// Parses and checks the flags: nullopt and plan filled, or the exit code
// (0 after --help).
std::optional<int> parseLoopFlags(int argc, char** argv, LoopPlan& plan);

// Each process's command line under the plan.
std::vector<std::string> serverCommand(const LoopPlan& plan, const std::string& port_file);
std::vector<std::string> podCommand(const LoopPlan& plan, int pod, const std::string& endpoint);
std::vector<std::string> clientCommand(const LoopPlan& plan, const std::string& endpoint,
                                       int index);
// Where client `index` writes: OUT itself when it is the only one.
std::string clientOut(const LoopPlan& plan, int index);
// A replay that is not looped ends by itself: the server leaves when its
// pods are done, and the client finishes after it.
bool replayEnds(const LoopPlan& plan);

}  // namespace holofuse::deploy
