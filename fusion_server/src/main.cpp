// fusion_server: syncs pod frames, carves the visual hull, fans out to
// render clients. Its --help lists the flags.
#include <algorithm>
#include <csignal>
#include <cstdio>

#include "base/process.h"
#include "base/shutdown.h"
#include "config/command_line.h"
#include "config/rig_shape.h"
#include "fusion_server/fusion_server.h"
#include "hull/vulkan_hull_grid.h"
#include "protocol/auth.h"
#include "protocol/messages.h"

namespace {

// --new-key: per-identity keys by default (SECURITY.md, docs/runbook.md).
int writeNewKeys(const std::string& where, int pods, uint32_t clients, bool shared) {
  using namespace holofuse;
  if (shared) {
    const Status written = protocol::KeyRing::writeNew(where);
    if (!written.isOk()) {
      std::fprintf(stderr, "--new-key: %s\n", written.message().c_str());
      return 2;
    }
    std::printf(
        "wrote one shared key to %s (mode 0600); give it to the server, pods and clients with "
        "--key-file\nwarning: every holder of a shared key can claim any pod and any client; "
        "leave out --shared-key for a key per identity (SECURITY.md)\n",
        where.c_str());
    return 0;
  }
  std::vector<uint32_t> client_ids(clients);
  for (uint32_t i = 0; i < clients; ++i) client_ids[i] = i;
  const auto written = protocol::KeyRing::writeRig(where, static_cast<uint32_t>(pods), client_ids);
  if (!written.isOk()) {
    std::fprintf(stderr, "--new-key: %s\n", written.status().message().c_str());
    return 2;
  }
  std::printf("wrote a key per identity (mode 0600):\n");
  for (size_t i = 0; i < written->size(); ++i) {
    std::printf("  %s%s\n", (*written)[i].c_str(),
                i == 0 ? "   the server's ring (--key-file of fusion_server only)" : "");
  }
  std::printf(
      "give each pod and client only its own file (--key-file); a pod holding pod-3.key can "
      "be pod 3 and nothing else. Hand-out: docs/runbook.md\n");
  return 0;
}

// The limits on what each peer may send and hold, and how long it may
// misbehave (SECURITY.md).
void addLimitOptions(CLI::App& app, holofuse::fusion::ServerOptions& options) {
  using namespace holofuse;
  app.add_option("--handshake-timeout-ms", options.handshake_timeout_ms,
                 "close a peer that has not finished its handshake after this long")
      ->check(CLI::Range(100, 60000));
  app.add_option("--read-budget-bytes", options.read_budget_bytes,
                 "bytes read from one peer per turn of the loop, so no peer starves the others")
      ->check(CLI::Range(size_t{65536}, size_t{1} << 30));
  app.add_option("--min-heartbeat-interval-ms", options.min_heartbeat_interval_ms,
                 "close a peer whose heartbeats come closer together than this")
      ->check(CLI::Range(1, 10000));
  app.add_option("--clock-drift-warn-ms", options.clock_drift_warn_ms,
                 "warn when a peer's clock moves this far from its first estimate, beyond the "
                 "estimates' uncertainty (its host needs chrony or linuxptp)")
      ->check(CLI::Range(0.001, 60000.0));
  app.add_option("--clock-probe-interval-ms", options.clock.interval_ms,
                 "between probes of each peer's clock (protocol 1.8)")
      ->check(CLI::Range(10, 600000));
  app.add_option("--max-image-side", options.max_image_side,
                 "the largest image width or height a pod's calibration may claim")
      ->check(CLI::Range(16, static_cast<int>(protocol::kMaxImageSide)));
  app.add_option("--decode-threads", options.decode_threads,
                 "threads that decompress pods' frames, off the loop that reads every peer")
      ->check(CLI::Range(1, 64));
  app.add_option("--max-frames-in-flight", options.max_frames_in_flight,
                 "a pod's frames read and not yet decoded before it is not read")
      ->check(CLI::Range(size_t{1}, size_t{1024}));
  app.add_option("--max-connections", options.max_connections,
                 "connections at once; one more is refused")
      ->check(CLI::Range(size_t{1}, size_t{65536}));
  app.add_option("--max-handshaking", options.max_handshaking,
                 "connections at once that have not finished their handshake")
      ->check(CLI::Range(size_t{1}, size_t{65536}));
  app.add_option("--max-handshaking-per-address", options.max_handshaking_per_address,
                 "connections from one address that have not finished their handshake")
      ->check(CLI::Range(size_t{1}, size_t{65536}));
  app.add_option("--max-peer-buffered-bytes", options.max_peer_buffered_bytes,
                 "bytes one peer may hold in the server, coming in and queued to go out")
      ->check(CLI::Range(size_t{1} << 20, size_t{1} << 40));
  app.add_option("--max-buffered-bytes", options.max_buffered_bytes,
                 "bytes all peers together may hold; past it the peer holding most is closed")
      ->check(CLI::Range(size_t{1} << 20, size_t{1} << 40));
  app.add_option("--max-id-skew", options.max_id_skew,
                 "frame ids a pod's frames may be from the rig's clock (the median of the pods' "
                 "ids); further off they are dropped")
      ->check(CLI::Range(uint64_t{1}, uint64_t{1000000}));
  app.add_option("--off-clock-close-ms", options.off_clock_close_ms,
                 "close a pod whose frame ids stay off the rig's clock this long")
      ->check(CLI::Range(100, 3600000));
  app.add_option("--over-budget-close-ms", options.over_budget_close_ms,
                 "close a peer that keeps sending some message type faster than its budget "
                 "(SECURITY.md) for this long")
      ->check(CLI::Range(100, 600000));
  app.add_option("--max-pod-fps", options.budget.pod_frame.per_second,
                 "PodFrames a pod may send a second (with --lossless, pods are read only as "
                 "fusion keeps up instead)")
      ->check(CLI::Range(1.0, 100000.0));
  app.add_option("--max-pod-cost-ratio", options.max_pod_cost_ratio,
                 "a pod's image may have at most this many times the pixels of the rig's median "
                 "pod (a rig of mixed cameras raises it)")
      ->check(CLI::Range(1.0, 1e6));
}

// --hull-device vulkan: the hull carved on the device, or on the CPU with
// a line that says why.
void openHullDevice(holofuse::hull::HullOptions& hull) {
  try {
    auto grid = holofuse::hull::VulkanHullGrid::open();
    std::printf("[server] hull carved on %s%s\n", grid->deviceName().c_str(),
                grid->cpuDevice() ? " (a CPU device)" : "");
    hull.surface = holofuse::hull::deviceSurface(std::move(grid));
  } catch (const std::exception& e) {
    std::printf("[server] hull carved on the CPU: no Vulkan device opened (%s)\n", e.what());
  }
  std::fflush(stdout);
}

// --volume x0,y0,z0,x1,y1,z1: the hull's capture volume; false, said why,
// when it is not one.
bool setVolume(const std::string& volume, holofuse::hull::HullOptions& hull) {
  double v[6];
  char tail = 0;
  if (std::sscanf(volume.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &v[3], &v[4],
                  &v[5], &tail) != 6 ||
      !(v[0] < v[3] && v[1] < v[4] && v[2] < v[5])) {
    std::fprintf(stderr, "--volume '%s': expected x0,y0,z0,x1,y1,z1 with each min below its max\n",
                 volume.c_str());
    return false;
  }
  holofuse::hull::setCaptureVolume(hull, glm::dvec3(v[0], v[1], v[2]),
                                   glm::dvec3(v[3], v[4], v[5]));
  return true;
}

// The keys the server authenticates peers with, or none with --no-auth
// (loopback only). False, having said why, when neither can serve.
bool takeKeys(holofuse::fusion::ServerOptions& options, bool no_auth, const std::string& key_path,
              const std::string& listen) {
  using namespace holofuse;
  if (!no_auth && !fusion::capabilitiesOf(options.max_minor).authenticates) {
    std::fprintf(stderr,
                 "--protocol 1.%u has no authentication (it came with 1.4): give --no-auth, or "
                 "1.4 or later\n",
                 options.max_minor);
    return false;
  }
  if (no_auth) {
    if (!protocol::isLoopback(options.listen)) {
      std::fprintf(stderr,
                   "--no-auth serves only loopback (127.0.0.1 or ::1), not %s: every peer would be "
                   "trusted; give a --key-file instead\n",
                   listen.c_str());
      return false;
    }
    std::fprintf(stderr,
                 "[server] no authentication (--no-auth): any local process may join; loopback "
                 "only\n");
  } else if (key_path.empty()) {
    std::fprintf(
        stderr,
        "[server] no key: give --key-file PATH (make one with fusion_server --new-key "
        "PATH) or set HOLOFUSE_KEY_FILE; or --no-auth to serve loopback unauthenticated\n");
    return false;
  } else {
    auto keys = protocol::KeyRing::load(key_path);
    if (!keys.isOk()) {
      std::fprintf(stderr, "[server] cannot start: %s\n", keys.status().message().c_str());
      return false;
    }
    options.keys = std::move(*keys);
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace holofuse;
  fusion::ServerOptions options;
  std::string listen = "127.0.0.1:7300";
  CLI::App app{"holofuse fusion_server: visual hull fusion and fan-out"};
  app.add_option("--listen", listen, "HOST:PORT to listen on (port 0: any free port)")
      ->capture_default_str();
  // The rig's --pods, from its table: the cameras expected.
  const SettingFlags<RigShape> shape_flags(app, pickSettings(rigShapeFlags(), {"--pods"}));
  app.add_option("--sync-deadline-ms", options.sync_deadline_ms,
                 "wait this long for a frame's slowest pod")
      ->check(CLI::Range(1.0, 10000.0));
  const SettingFlags<fusion::FusionSettings> fusion_flags(app, fusion::fusionFlags());
  std::string volume;
  app.add_option("--volume", volume,
                 "capture volume min and max corners x0,y0,z0,x1,y1,z1 in metres (a dataset's)");
  app.add_option("--client-queue", options.client_queue_frames,
                 "frames queued per client before dropping the oldest")
      ->check(CLI::Range(1, 1024));
  app.add_option("--idle-timeout-ms", options.idle_timeout_ms,
                 "close a silent peer after this long")
      ->check(CLI::Range(100, 600000));
  app.add_option("--port-file", options.port_file, "write the bound port to this file");
  app.add_option("--health-file", options.health_file,
                 "rewrite the server's state (JSON) into this file every second while serving");
  std::string check_health;
  uint32_t health_max_age_ms = 5000;
  app.add_option("--check-health", check_health,
                 "probe: exit 0 when this health file says serving and is fresh, else 1 saying "
                 "why (liveness and readiness)");
  app.add_option("--health-max-age-ms", health_max_age_ms,
                 "with --check-health: the oldest a health file may be")
      ->check(CLI::Range(100, 600000));
  app.add_option(
      "--record", options.record_dir,
      "record what the pods send (calibration and every frame, as received) into this folder");
  app.add_flag("--record-fused", options.record_fused,
               "with --record: also record the fused meshes and images");
  app.add_flag(
      "--lossless", options.lossless,
      "fuse every frame of every pod: no sync deadline, no dropped group; pods ahead are not read");
  bool fuse_every_group = false;
  app.add_flag("--fuse-every-group", fuse_every_group,
               "fuse every group the pods send, also while every client (protocol 1.9 and later) "
               "has all the frames it asked for (by default such groups are not fused)");
  app.add_option("--wait-for-clients", options.wait_for_clients,
                 "read nothing from pods until this many render clients have joined (replays)")
      ->check(CLI::Range(0, 64));
  app.add_flag(
      "--exit-when-pods-done", options.exit_when_pods_done,
      "stop once every pod has left and its frames are fused and delivered (end of a replay)");
  const ProtocolFlag protocol_flag(app, "server");
  std::string key_file, new_key;
  bool no_auth = false;
  app.add_option("--key-file", key_file,
                 "the keys pods and clients authenticate with (default: $HOLOFUSE_KEY_FILE); "
                 "SECURITY.md");
  app.add_flag("--no-auth", no_auth,
               "serve without authentication: every peer is trusted, so loopback only")
      ->excludes("--key-file");
  addLimitOptions(app, options);
  app.add_option("--new-key", new_key,
                 "write fresh keys into this folder and exit: server.keys (the server's ring), "
                 "pod-<i>.key for each of --pods pods and client-<j>.key for each of "
                 "--new-key-clients clients, each its own identity's only (mode 0600)");
  uint32_t new_key_clients = 1;
  app.add_option("--new-key-clients", new_key_clients, "with --new-key: client keys to write")
      ->check(CLI::Range(0, 1024));
  bool shared_key = false;
  app.add_flag("--shared-key", shared_key,
               "with --new-key: write one key file every peer shares instead (any holder can "
               "then claim any pod; SECURITY.md)");
  addRigFlag(app, "fusion_server", [](const RigFile& rig) -> StatusOr<std::vector<RigOption>> {
    return rig.serverPart();
  });
  HOLOFUSE_PARSE_FLAGS(app, argc, argv)
  RigShape shape;
  shape.pods = options.pods;
  shape_flags.apply(shape);
  options.pods = shape.pods;
  if (!check_health.empty()) {
    const auto health = fusion::checkHealth(check_health, health_max_age_ms);
    if (!health.isOk()) {
      std::fprintf(stderr, "unhealthy: %s\n", health.status().message().c_str());
      return 1;
    }
    std::printf("healthy: %s\n", health->c_str());
    return 0;
  }
  if (!new_key.empty()) return writeNewKeys(new_key, options.pods, new_key_clients, shared_key);
  fusion_flags.apply(options.fusion);
  if (options.fusion.hull_device == "vulkan") openHullDevice(options.fusion.hull);
  options.budget.pod_frame.burst =
      std::max(options.budget.pod_frame.burst, options.budget.pod_frame.per_second / 2);
  if (options.lossless) options.budget.pod_frame = {};  // read as fusion keeps up
  options.fuse_when_asked = !fuse_every_group;
  if (!volume.empty() && !setVolume(volume, options.fusion.hull)) return 2;
  if (options.record_fused && options.record_dir.empty()) {
    std::fprintf(stderr, "--record-fused needs --record DIR\n");
    return 2;
  }
  auto endpoint = protocol::parseEndpoint(listen);
  if (!endpoint.isOk()) {
    std::fprintf(stderr, "--listen: %s\n", endpoint.status().message().c_str());
    return 2;
  }
  options.listen = *endpoint;
  options.max_minor = protocol_flag.maxMinor();
  if (!takeKeys(options, no_auth, protocol::keyFilePath(key_file), listen)) return 2;
  installStopSignals();
  const FreeMemoryReturner free_memory;
  // A recording that reaches a file size limit gets EFBIG from write() and
  // is reported like a full disk, instead of the signal ending the server.
  signal(SIGXFSZ, SIG_IGN);
  fusion::FusionServer server(options);
  const Status started = server.start();
  if (!started.isOk()) {
    std::fprintf(stderr, "[server] cannot start: %s\n", started.toString().c_str());
    return 1;
  }
  return server.run();
}
