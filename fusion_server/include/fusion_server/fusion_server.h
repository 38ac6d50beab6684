// The fusion server's session part and its I/O loop: one port for pods and
// clients (the role is in Hello); accept with caps on connections, the
// handshake (version, authentication, capabilities), heartbeats and clock
// probes, budgets and limits on what each peer sends and holds. What the
// pods send goes to the pipeline part (frame_pipeline.h: sync, fusion,
// fan-out, recording). A malformed message closes only the connection that
// sent it.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "fusion_server/frame_pipeline.h"
#include "fusion_server/peer.h"
#include "fusion_server/server_options.h"
#include "protocol/socket.h"

namespace holofuse::fusion {

class FusionServer {
 public:
  explicit FusionServer(ServerOptions options);

  // Binds the port (or says why not).
  Status start();
  uint16_t port() const { return listener_.localPort(); }
  // Serves until stopRequested(); says Bye to everyone on the way out.
  int run();

 private:
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
  Status handleClockProbe(Peer& peer, const protocol::Frame& frame);
  Status handleFrameRequest(Peer& peer, const protocol::Frame& frame);
  // What a client takes, from its capability bits (its Hello's, or since
  // 1.10 its latest FrameRequest's): texture layers where they fit the
  // meshes it decodes, as video where the server codes them.
  void setLayersTaken(Peer& peer, uint64_t capability_bits);
  static std::string layersTakenNote(const Peer& peer);
  // A refused connection is told why and closed before it is a peer.
  void refuseConnection(protocol::Socket socket, const std::string& name, const std::string& why);
  // Past the global cap on buffered bytes: the peer holding most goes.
  void enforceBufferedBytes();
  void closePeer(size_t index, const Status& why);
  // health_file, rewritten whole (written aside, then renamed).
  void writeHealth(const char* state);

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
  FramePipeline pipeline_;  // reads options_
  // Out of descriptors: the listener is not polled until then, so it
  // cannot spin, and the backlog holds the connections meanwhile.
  uint64_t accept_paused_until_ns_ = 0;
  uint64_t accept_pauses_ = 0;
  uint64_t made_room_ = 0;  // connections closed to make room for a newer one
  // The median of the connected pods' image pixels, and their count.
  std::pair<uint64_t, size_t> rig_pixels_{0, 0};
  protocol::Socket listener_;
  std::vector<Peer> peers_;
  std::map<uint32_t, Camera> cameras_;  // each pod's, from its Calibration
  uint64_t next_serial_ = 1;
  uint64_t health_written_ns_ = 0;
  bool health_failed_ = false;  // said once
  uint64_t refused_connections_ = 0;
  uint32_t next_session_ = 1;
};

// The probe of a server's health file (ServerOptions::health_file): ok,
// with a line that says what it serves, when the file was rewritten within
// max_age_ms and says "serving"; else an error that says what is wrong (no
// file, stale, stopped, unreadable).
StatusOr<std::string> checkHealth(const std::string& path, uint32_t max_age_ms);

}  // namespace holofuse::fusion
