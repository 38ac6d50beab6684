// Everything the fusion server is started with (fusion_server --help
// names each as a flag); the session part and the pipeline part read it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "fusion_server/frame_sync.h"
#include "fusion_server/fusion_worker.h"
#include "fusion_server/peer_budget.h"
#include "protocol/auth.h"
#include "protocol/clock_sync.h"
#include "protocol/socket.h"

namespace holofuse::fusion {

struct ServerOptions {
  protocol::Endpoint listen;
  int pods = 4;
  double sync_deadline_ms = 150.0;
  size_t client_queue_frames = 6;  // droppable frames queued per client
  uint32_t heartbeat_interval_ms = 500;
  uint32_t idle_timeout_ms = 5000;
  uint32_t max_payload = protocol::kDefaultMaxPayload;
  FusionSettings fusion;
  std::string port_file;  // when set, the bound port is written here (port 0 use)
  // When set, the server's state as JSON, rewritten every second while it
  // serves (fusion_server --check-health reads it: liveness and readiness
  // probes, docs/runbook.md).
  std::string health_file;
  std::string record_dir;     // when set, what the pods send is recorded here
  bool record_fused = false;  // with record_dir: the fused output too
  // Replay as fast as the server accepts: every group waits for all its
  // pods, no group is dropped, and pods that are ahead are not read
  // (backpressure through TCP) until fusion catches up.
  bool lossless = false;
  // Fuse a group only while some client asked for a frame (protocol 1.9
  // FrameRequest), when every client asks: a slow client costs no fusion
  // it would not render. Off, or with --lossless, --record-fused or a
  // client that does not ask, every group is fused.
  bool fuse_when_asked = true;
  // Stop (saying Bye) once every pod that joined has left and everything
  // they sent is fused and delivered: the end of a replay.
  bool exit_when_pods_done = false;
  // Pods are not read until this many clients have joined, so a replay's
  // first frames reach the client too.
  int wait_for_clients = 0;
  // The keys peers authenticate with (protocol/auth.h); none: --no-auth,
  // every peer is trusted (loopback only, main.cpp checks).
  std::optional<protocol::KeyRing> keys;
  // A peer that has not finished its handshake (Hello, and the challenge
  // when there are keys) by then is closed.
  uint32_t handshake_timeout_ms = 2000;
  // Fair service (SECURITY.md): bytes read from one peer per turn of the
  // loop; heartbeats closer together than this are refused (a peer sends
  // one only after heartbeat_interval_ms of sending nothing else); and the
  // largest image side a pod's calibration may claim, which bounds every
  // plane the server decompresses for it.
  size_t read_budget_bytes = 4u << 20;
  uint32_t min_heartbeat_interval_ms = 50;
  uint32_t max_image_side = 4096;
  // Each peer's clock is probed (protocol/clock_sync.h); the log warns when
  // one moves more than this from its first estimate, beyond the
  // estimates' uncertainty (its host's clock is not disciplined).
  double clock_drift_warn_ms = 1.0;
  // The newest protocol minor agreed with any peer (--protocol): a server
  // standing in for an older release during a rolling upgrade.
  uint8_t max_minor = protocol::kVersionMinor;
  protocol::ClockSyncOptions clock;
  // Pods' frames are decompressed on this many threads, off the loop.
  int decode_threads = 1;
  // Limits before allocation (SECURITY.md). Frames of one pod read and not
  // yet decoded: at this many the pod is not read (TCP holds the rest).
  size_t max_frames_in_flight = 4;
  // Connections in all; of them, not yet through the handshake; and of
  // those, from one address. A connection past a cap is closed at once.
  size_t max_connections = 256;
  size_t max_handshaking = 64;
  size_t max_handshaking_per_address = 16;
  // Bytes one peer may hold (frames coming in and queued to go out), and
  // all peers together; past the global cap the peer holding most is
  // closed.
  size_t max_peer_buffered_bytes = 256u << 20;
  size_t max_buffered_bytes = 1024u << 20;
  // The rig's clock (frame_sync.h): a pod's frames further than this many
  // ids from it are dropped, and a pod off it this long is closed.
  uint64_t max_id_skew = FrameSync::kDefaultMaxIdSkew;
  uint32_t off_clock_close_ms = 3000;
  // What an admitted peer may send, per message type (peer_budget.h); a
  // peer over a budget waits, and one over it for this long is closed.
  BudgetTable budget;
  uint32_t over_budget_close_ms = 2000;
  // A pod's image may have at most this many times the pixels of the
  // rig's median pod (of those connected): what its frames cost to
  // decompress, hold and fuse, and what each client then decodes and
  // uploads, is bounded by the rig's, whatever its key allows.
  double max_pod_cost_ratio = 4.0;
};

}  // namespace holofuse::fusion
