// One connection the fusion server holds, and what it has proved and
// agreed: the session part's (fusion_server.h) state of the peer, which the
// pipeline part (frame_pipeline.h) reads to pace and fan out to clients.
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "base/status.h"
#include "fusion_server/peer_budget.h"
#include "fusion_server/peer_capabilities.h"
#include "protocol/auth.h"
#include "protocol/clock_sync.h"
#include "protocol/connection.h"
#include "protocol/messages.h"

namespace holofuse::fusion {

// The most frames a client may be owed: frames asked for are never dropped
// from its queue, so this bounds what it holds in the server.
inline constexpr uint64_t kMostFramesAhead = 8;

struct Peer {
  std::unique_ptr<protocol::Connection> connection;
  uint64_t serial = 0;  // names the connection to the pod decoder
  bool greeted = false;
  protocol::Role role = protocol::Role::kPod;
  uint32_t id = 0;
  bool replaced = false;  // a newer connection of the same pod took over
  bool isClient() const { return greeted && role == protocol::Role::kClient; }
  // From the version agreed in the handshake: what this peer is sent.
  PeerCapabilities caps;
  bool wants_layers = false;  // a client that asked for texture layers that fit its meshes
  // ... and for the layers' colour as video (and the server codes it);
  // until it gets a key frame its stream is not in step.
  bool wants_layer_video = false;
  bool layer_video_in_step = false;
  // A client that asks for frames (FrameRequest, caps.asks_for_frames)
  // is sent only what it asked for: MeshFrames until it has been sent
  // frames_through on this connection (at most kMostFramesAhead beyond
  // those sent).
  uint64_t frames_through = 0;
  uint64_t frames_sent = 0;
  uint64_t framesOwed() const {
    if (frames_through <= frames_sent) return 0;
    return std::min(frames_through - frames_sent, kMostFramesAhead);
  }
  uint64_t frames_dropped_seen = 0;  // the connection's drops at the last fan-out
  uint64_t accepted_ns = 0;
  uint64_t last_heartbeat_ns = 0;
  uint32_t early_heartbeats = 0;  // in a row, each closer than the floor
  uint64_t last_probe_ns = 0;     // the peer's last clock probe request
  uint32_t early_probes = 0;      // in a row, each closer than the floor
  uint64_t read_ns = 0;           // when the frames being handled were read
  // The peer's clock against ours (peers of 1.8 or later answer probes).
  protocol::ClockSync clock;
  bool clock_told = false;         // its first estimate is in the log
  bool drift_warned = false;       // its drift past the threshold is in the log
  uint64_t bad_probe_answers = 0;  // logged the first and every 100th
  // Between Hello and the answer to our challenge: what was claimed, the
  // version agreed and the challenge sent.
  struct PendingAuth {
    protocol::Hello hello;
    protocol::HelloAck ack;
    protocol::AuthBytes challenge;
    const std::vector<uint8_t>* key = nullptr;
  };
  std::optional<PendingAuth> pending;
  // What it may send once admitted; a frame over budget waits here, and
  // the peer is not read, until paused_until_ns.
  PeerBudget budget;
  std::optional<protocol::Frame> held;
  uint64_t paused_until_ns = 0;
  bool calibrated = false;  // a pod that sent its Calibration on this connection
  // Set while another peer is handled: the loop closes this one for it.
  std::optional<Status> close_now;
};

}  // namespace holofuse::fusion
