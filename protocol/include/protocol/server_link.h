// ServerLink: the connecting side of a pod or client. Connects, handshakes,
// reconnects with capped exponential backoff (saying so), sends heartbeats
// when idle and gives up on a silent server after the idle timeout.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "protocol/auth.h"
#include "protocol/clock_sync.h"
#include "protocol/connection.h"
#include "protocol/messages.h"
#include "protocol/socket.h"

namespace holofuse::protocol {

struct LinkOptions {
  int connect_timeout_ms = 1000;
  int backoff_initial_ms = 100;
  int backoff_max_ms = 2000;
  uint32_t heartbeat_interval_ms = 500;
  uint32_t idle_timeout_ms = 5000;
  ConnectionLimits limits;
  std::string log_name = "link";  // prefix of log lines
  // The key of our identity (protocol/auth.h); empty: none. With a key the
  // link answers the server's challenge and accepts only a server that
  // proves it holds the key too; without one it can join only a server
  // started with --no-auth.
  std::vector<uint8_t> key;
  // Probes of the server's clock (a server of 1.8 or later answers them).
  ClockSyncOptions clock;
  // A client's fused frames asked for ahead (FrameRequest, 1.9): this many
  // after the handshake, then one more as each MeshFrame arrives, so that
  // the server fuses the next while this one renders. 0: it asks for none
  // and is sent every frame the server fuses.
  uint32_t frames_ahead = 0;
};

class ServerLink {
 public:
  ServerLink(Endpoint server, Hello hello, LinkOptions options);

  // One turn of I/O: connects when the backoff allows, waits up to
  // timeout_ms for the socket, reads, writes, heartbeats, checks the idle
  // timeout. Frames other than handshake and heartbeats go to received.
  void poll(int timeout_ms, std::vector<Frame>& received);

  // Handshake complete and the connection alive.
  bool ready() const { return connection_ != nullptr && acked_; }
  // True once after every completed handshake (to resend what a new
  // connection needs, such as Calibration).
  bool takeConnectedEvent();
  // Set when the server refused us for good (version mismatch): retrying
  // cannot help.
  const std::optional<Status>& fatalError() const { return fatal_; }
  // The server closed with Bye (it shut down), as opposed to a lost
  // connection; stays set until the next handshake.
  bool serverSaidBye() const { return server_said_bye_; }

  void send(SharedFrame frame);
  template <typename Message>
  void sendMessage(const Message& m) {
    send(std::make_shared<const OutgoingFrame>(encodeOutgoing(m, nextSequence())));
  }
  // Sends Bye with the reason and closes in order, waiting up to
  // timeout_ms for everything queued to leave and the server to close.
  void close(const std::string& reason, int timeout_ms = 500);

  // The server's clock against ours on this connection (not known before
  // the first answer, nor from a server before 1.8).
  const ClockSync& clock() const { return clock_; }
  // The version agreed in the last handshake.
  uint8_t agreedMinor() const { return agreed_minor_; }

  // A client's texture layers (Hello's bits kCapabilityLayers and
  // kCapabilityLayerVideo), changed while it runs: said to a server of
  // 1.10 or later at once (FrameRequest), and in the Hello of every later
  // connection. Whether the server heard it now; an older one goes on
  // sending what the Hello asked for.
  bool takeLayers(uint64_t capability_bits);
  uint64_t layersTaken() const { return hello_.capabilities & kLayerBits; }
  bool changesLayers() const { return ready() && agreed_minor_ >= 10; }

  uint64_t connects() const { return connects_; }
  uint64_t bytesOut() const {
    return bytes_out_closed_ + (connection_ ? connection_->bytesOut() : 0);
  }
  uint64_t bytesIn() const { return bytes_in_closed_ + (connection_ ? connection_->bytesIn() : 0); }
  uint64_t framesDropped() const {
    return dropped_closed_ + (connection_ ? connection_->framesDropped() : 0);
  }
  size_t queuedFrames() const { return connection_ ? connection_->queuedFrames() : 0; }

 private:
  void tryConnect();
  void fail(const Status& why);
  void handle(Frame frame, std::vector<Frame>& received);
  bool asksForFrames() const { return options_.frames_ahead > 0 && agreed_minor_ >= 9; }
  void askForFrames() {
    connection_->sendMessage(FrameRequest{meshes_ + options_.frames_ahead, layersTaken()});
  }
  static constexpr uint64_t kLayerBits = kCapabilityLayers | kCapabilityLayerVideo;
  // The server's Auth before its HelloAck: answer its challenge, check its
  // proof. An error is fatal: a key does not become right by retrying.
  Status handleAuth(const Frame& frame);

  Endpoint server_;
  Hello hello_;  // its nonce is drawn afresh for every connection (tryConnect)
  LinkOptions options_;
  std::unique_ptr<Connection> connection_;
  bool acked_ = false;
  uint8_t agreed_minor_ = 0;
  uint64_t hello_layers_ = 0;  // the layer bits of the Hello on this connection
  uint64_t meshes_ = 0;        // MeshFrames received on this connection
  ClockSync clock_;
  uint64_t read_ns_ = 0;                               // when the frames being handled were read
  std::optional<AuthBytes> challenge_;                 // the server's, on this connection
  uint8_t challenge_major_ = 0, challenge_minor_ = 0;  // the version it came under
  bool server_proved_ = false;
  bool connected_event_ = false;
  bool server_said_bye_ = false;
  std::optional<Status> fatal_;
  int backoff_ms_ = 0;
  uint64_t next_attempt_ns_ = 0;
  uint64_t connects_ = 0;
  uint64_t attempts_failed_ = 0;
  uint64_t bytes_out_closed_ = 0, bytes_in_closed_ = 0, dropped_closed_ = 0;
  uint32_t heartbeat_interval_ms_;
  uint32_t idle_timeout_ms_;
};

}  // namespace holofuse::protocol
