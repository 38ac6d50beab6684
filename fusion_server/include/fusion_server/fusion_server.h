// The fusion server's I/O loop: one port for pods and clients (the role is
// in Hello), handshake, calibration relay, frame sync, fusion on a worker
// thread and fan-out to every client through its own bounded queue. A
// malformed message closes only the connection that sent it.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "base/arrival_jitter.h"
#include "common/camera.h"
#include "dataset/recorder.h"
#include "fusion_server/frame_sync.h"
#include "fusion_server/fusion_worker.h"
#include "fusion_server/peer_budget.h"
#include "fusion_server/pod_decoder.h"
#include "protocol/auth.h"
#include "protocol/clock_sync.h"
#include "protocol/connection.h"
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

class FusionServer {
 public:
  explicit FusionServer(ServerOptions options);
  ~FusionServer();

  // Binds the port (or says why not).
  Status start();
  uint16_t port() const { return listener_.localPort(); }
  // Serves until stopRequested(); says Bye to everyone on the way out.
  int run();

 private:
  struct Peer {
    std::unique_ptr<protocol::Connection> connection;
    uint64_t serial = 0;  // names the connection to the pod decoder
    bool greeted = false;
    protocol::Role role = protocol::Role::kPod;
    uint32_t id = 0;
    bool replaced = false;      // a newer connection of the same pod took over
    uint8_t minor = 0;          // agreed in the handshake: the fields this peer is sent
    bool wants_layers = false;  // a client of 1.5 or later that asked for texture layers
    // A client of 1.6 that asked for the layers' colour as video (and the
    // server codes it); until it gets a key frame its stream is not in step.
    bool wants_layer_video = false;
    bool layer_video_in_step = false;
    // A client of 1.9 that said in its Hello it asks for frames
    // (FrameRequest) is sent only what it asked for: MeshFrames until it
    // has been sent frames_through on this connection (at most
    // kMostFramesAhead beyond those sent).
    bool asks_for_frames = false;
    uint64_t frames_through = 0;
    uint64_t frames_sent = 0;
    uint64_t framesOwed() const;
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

  void acceptAll();
  // Admission that honest peers win (SECURITY.md): when the handshake
  // slots, the connections or the descriptors run out, the connection
  // that has been in its handshake longest without proving anything is
  // closed to make room, rather than the newcomer refused. A pending
  // claim to be one of the rig's pods is kept (at most two per pod id, the
  // newest), so a crowd cannot keep a restarting pod out. False when no
  // such connection is left to close.
  bool makeRoom(const std::string& why);
  // A third pending claim of the same pod id: the oldest is closed.
  void limitPodClaims(uint32_t pod);
  // Handles the frames read from a peer, each charged to its budget, until
  // one is over it (held, the peer paused) or the inbox is empty. status
  // is the read's, returned unless a frame's handling fails.
  Status handleInbox(Peer& peer, Status status);
  // Handles one frame; a non-ok status closes that peer.
  Status handle(Peer& peer, protocol::Frame frame);
  Status handleHello(Peer& peer, const protocol::Frame& frame);
  Status handleAuthAnswer(Peer& peer, const protocol::Frame& frame);
  // The peer is who it says (or there is no authentication): it joins.
  Status admit(Peer& peer, const protocol::Hello& hello, protocol::HelloAck ack);
  Status handlePodFrame(Peer& peer, protocol::Frame frame);
  Status handleClockProbe(Peer& peer, const protocol::Frame& frame);
  Status handleFrameRequest(Peer& peer, const protocol::Frame& frame);
  // Whether groups are fused only as clients ask (ServerOptions::
  // fuse_when_asked), and whether one more may start now.
  bool fusingWhenAsked() const;
  bool aClientWaitsForAFrame();
  void submitGroup(FrameGroup group);
  // A refused connection is told why and closed before it is a peer.
  void refuseConnection(protocol::Socket socket, const std::string& name, const std::string& why);
  void takeDecodedFrames();
  void syncDecoded(protocol::Frame frame, uint32_t pod, uint64_t frame_id, PodImages images);
  // Past the global cap on buffered bytes: the peer holding most goes.
  void enforceBufferedBytes();
  void dispatchReadyGroups();
  void fanOut();
  void closePeer(size_t index, const Status& why);
  std::set<uint32_t> expectedPods() const;
  // Lossless mode: false while this pod is ahead of fusion (not read).
  bool readable(const Peer& peer);
  bool podsDone();
  // health_file, rewritten whole (written aside, then renamed).
  void writeHealth(const char* state);

  // A pod's frame off the rig's clock: told in the log (the first of a
  // run and every 100th).
  void tellOffClock(uint32_t pod, uint64_t frame_id);
  // Why a peer is to be closed for how it behaves (marked by another's
  // handling, off the rig's clock too long, too costly a pod, over its
  // budget too long); ok while it behaves.
  Status standing(const Peer& peer, uint64_t now_ns) const;
  // A pod off the rig's clock for longer than off_clock_close_ms: why it
  // is closed; ok otherwise.
  Status offClockTooLong(const Peer& peer, uint64_t now_ns) const;

  // rig_pixels_ anew: measured when a pod's calibration arrives or a
  // calibrated pod leaves, not on every frame or turn of the loop.
  void measureRigPixels();
  // A pod whose image costs more than max_pod_cost_ratio times the rig's
  // median pod: why it is closed; ok otherwise.
  Status podCostTooHigh(const Peer& peer) const;

  ServerOptions options_;
  // Out of descriptors: the listener is not polled until then, so it
  // cannot spin, and the backlog holds the connections meanwhile.
  uint64_t accept_paused_until_ns_ = 0;
  uint64_t accept_pauses_ = 0;
  uint64_t made_room_ = 0;  // connections closed to make room for a newer one
  // The median of the connected pods' image pixels, and their count.
  std::pair<uint64_t, size_t> rig_pixels_{0, 0};
  protocol::Socket listener_;
  int wake_fd_ = -1;
  std::vector<Peer> peers_;
  std::map<uint32_t, Camera> cameras_;
  std::map<uint32_t, ArrivalJitter> pod_arrivals_;  // per pod, over every PodFrame received
  std::set<uint32_t> departed_pods_;                // pods that joined and then left
  std::map<uint32_t, protocol::SharedFrame> calibration_frames_;
  FrameSync sync_;
  std::unique_ptr<FusionWorker> worker_;
  std::unique_ptr<PodDecoder> decoder_;
  uint64_t next_serial_ = 1;
  uint64_t health_written_ns_ = 0;
  bool health_failed_ = false;  // said once
  uint64_t refused_connections_ = 0;
  uint32_t next_session_ = 1;
  uint64_t groups_fused_ = 0;
  // The newest ready group no client has asked for yet; a newer one
  // replaces it (counted: groups_not_asked_for_).
  std::optional<FrameGroup> held_group_;
  uint64_t groups_not_asked_for_ = 0;
  // The most frames a client may be owed: frames asked for are never
  // dropped from its queue, so this bounds what it holds in the server.
  static constexpr uint64_t kMostFramesAhead = 8;
  std::optional<dataset::Recorder> recorder_;
  bool clients_arrived_ = false;  // wait_for_clients reached once
};

// The probe of a server's health file (ServerOptions::health_file): ok,
// with a line that says what it serves, when the file was rewritten within
// max_age_ms and says "serving"; else an error that says what is wrong (no
// file, stale, stopped, unreadable).
StatusOr<std::string> checkHealth(const std::string& path, uint32_t max_age_ms);

}  // namespace holofuse::fusion
