#include "protocol/server_link.h"

#include <poll.h>

#include <cstdio>

#include "protocol/clock.h"
#include "protocol/handshake.h"

namespace holofuse::protocol {

ServerLink::ServerLink(Endpoint server, Hello hello, LinkOptions options)
    : server_(std::move(server)),
      hello_(std::move(hello)),
      options_(std::move(options)),
      heartbeat_interval_ms_(options_.heartbeat_interval_ms),
      idle_timeout_ms_(options_.idle_timeout_ms) {
  // Said in the Hello, so that the server sends nothing before the first
  // request: every MeshFrame the link counts is one it asked for.
  if (options_.frames_ahead > 0) hello_.capabilities |= kCapabilityAsksForFrames;
}

bool ServerLink::takeConnectedEvent() {
  const bool event = connected_event_;
  connected_event_ = false;
  return event;
}

bool ServerLink::takeLayers(uint64_t capability_bits) {
  hello_.capabilities = (hello_.capabilities & ~kLayerBits) | (capability_bits & kLayerBits);
  if (!changesLayers()) return false;
  askForFrames();
  return true;
}

void ServerLink::tryConnect() {
  auto socket = connectTcp(server_, options_.connect_timeout_ms);
  const uint64_t now = monotonicNs();
  if (!socket.isOk()) {
    backoff_ms_ = backoff_ms_ == 0 ? options_.backoff_initial_ms
                                   : std::min(backoff_ms_ * 2, options_.backoff_max_ms);
    ++attempts_failed_;
    std::fprintf(stderr, "[%s] cannot reach server %s (%s); retry %llu in %d ms\n",
                 options_.log_name.c_str(), server_.toString().c_str(),
                 socket.status().message().c_str(),
                 static_cast<unsigned long long>(attempts_failed_), backoff_ms_);
    next_attempt_ns_ = now + static_cast<uint64_t>(backoff_ms_) * 1000000ull;
    return;
  }
  connection_ =
      std::make_unique<Connection>(std::move(*socket), server_.toString(), options_.limits);
  acked_ = false;
  challenge_.reset();
  server_proved_ = false;
  hello_.nonce = randomNonce();  // fresh per connection: an old proof is worth nothing
  hello_.send_time_ns = now;
  hello_layers_ = layersTaken();
  connection_->sendMessage(hello_);
}

void ServerLink::fail(const Status& why) {
  if (connection_ == nullptr) return;
  std::fprintf(stderr, "[%s] connection to %s lost: %s\n", options_.log_name.c_str(),
               server_.toString().c_str(), why.toString().c_str());
  bytes_out_closed_ += connection_->bytesOut();
  bytes_in_closed_ += connection_->bytesIn();
  dropped_closed_ += connection_->framesDropped();
  // A server that accepts the connection but refuses or stalls the
  // handshake is retried with growing backoff too; only a connection that
  // worked starts again from the initial delay.
  backoff_ms_ = acked_ ? options_.backoff_initial_ms
                       : std::min(std::max(backoff_ms_ * 2, options_.backoff_initial_ms),
                                  options_.backoff_max_ms);
  connection_.reset();
  acked_ = false;
  next_attempt_ns_ = monotonicNs() + static_cast<uint64_t>(backoff_ms_) * 1000000ull;
}

void ServerLink::handle(Frame frame, std::vector<Frame>& received) {
  const auto type = static_cast<MessageType>(frame.header.type);
  if (!acked_) {
    if (type == MessageType::kError) {
      ErrorMessage error;
      const Status decoded = decodeFrame(frame, error);
      const Status why(static_cast<StatusCode>(error.code),
                       decoded.isOk() ? "server refused: " + error.message : decoded.message());
      // A version or a key the server refuses stays refused on retry.
      if (error.code == static_cast<uint16_t>(StatusCode::kUnsupportedVersion) ||
          error.code == static_cast<uint16_t>(StatusCode::kUnauthenticated))
        fatal_ = why;
      fail(why);
      return;
    }
    if (type == MessageType::kAuth) {
      const Status s = handleAuth(frame);
      if (!s.isOk()) {
        // Tell the server why, so its log says it too.
        connection_->sendMessage(Bye{s.message()});
        connection_->drain(100);
        fatal_ = s;
        fail(s);
      }
      return;
    }
    HelloAck ack;
    Status s = decodeFrame(frame, ack);
    if (s.isOk()) s = checkAck(hello_, ack);
    if (s.isOk() && !options_.key.empty() && !server_proved_) {
      s = Status(StatusCode::kUnauthenticated,
                 "the server did not authenticate (it runs with --no-auth?); this " +
                     identityName(hello_.role, hello_.id) +
                     " holds a key and joins only a server that proves it holds it too");
      fatal_ = s;
    }
    if (!s.isOk()) {
      if (s.code() == StatusCode::kUnsupportedVersion) fatal_ = s;
      fail(s);
      return;
    }
    acked_ = true;
    agreed_minor_ = ack.minor;
    meshes_ = 0;
    // A change of layers while the handshake ran is told at once.
    if (asksForFrames() || (changesLayers() && layersTaken() != hello_layers_)) askForFrames();
    clock_ = ClockSync(options_.clock);  // a new connection may reach another host
    connected_event_ = true;
    server_said_bye_ = false;
    ++connects_;
    heartbeat_interval_ms_ =
        ack.heartbeat_interval_ms > 0 ? ack.heartbeat_interval_ms : options_.heartbeat_interval_ms;
    idle_timeout_ms_ = ack.idle_timeout_ms > 0 ? ack.idle_timeout_ms : options_.idle_timeout_ms;
    backoff_ms_ = 0;
    if (attempts_failed_ > 0) {
      std::fprintf(stderr, "[%s] connected to %s after %llu failed attempts\n",
                   options_.log_name.c_str(), server_.toString().c_str(),
                   static_cast<unsigned long long>(attempts_failed_));
      attempts_failed_ = 0;
    }
    return;
  }
  switch (type) {
    case MessageType::kHeartbeat:
      return;
    case MessageType::kClockProbe: {
      ClockProbe probe;
      Status s = decodeFrame(frame, probe);
      if (s.isOk() && probe.step == ProbeStep::kRequest) {
        connection_->sendMessage(ClockSync::answer(probe, read_ns_, monotonicNs()));
        return;
      }
      if (s.isOk()) s = clock_.onReply(probe, read_ns_);
      // The estimate keeps its last good samples; a bad answer is only told.
      if (!s.isOk())
        std::fprintf(stderr, "[%s] ignored a clock probe from the server: %s\n",
                     options_.log_name.c_str(), s.toString().c_str());
      return;
    }
    case MessageType::kBye: {
      Bye bye;
      (void)decodeFrame(frame, bye);
      server_said_bye_ = true;
      fail(Status(StatusCode::kClosed, "server said bye: " + bye.reason));
      return;
    }
    case MessageType::kMeshFrame:
      // Asked for before the caller decodes and renders it: the request
      // leaves at the end of this poll.
      ++meshes_;
      if (asksForFrames()) askForFrames();
      received.push_back(std::move(frame));
      return;
    default:
      received.push_back(std::move(frame));
  }
}

Status ServerLink::handleAuth(const Frame& frame) {
  Auth auth;
  HOLOFUSE_RETURN_IF_ERROR(decodeFrame(frame, auth));
  if (auth.step == AuthStep::kChallenge) {
    // The challenge goes out under the agreed version, which the MACs cover.
    challenge_major_ = frame.header.major;
    challenge_minor_ = frame.header.minor;
    if (options_.key.empty()) {
      return Status(StatusCode::kUnauthenticated,
                    "the server requires a key: give --key-file PATH or set HOLOFUSE_KEY_FILE");
    }
    if (challenge_) return Status(StatusCode::kUnexpectedMessage, "a second challenge");
    challenge_ = auth.value;
    Auth answer;
    answer.step = AuthStep::kResponse;
    answer.value = authMac(options_.key, AuthStep::kResponse, hello_, challenge_major_,
                           challenge_minor_, auth.value);
    connection_->sendMessage(answer);
    return Status::ok();
  }
  if (auth.step == AuthStep::kProof && challenge_) {
    const AuthBytes expected = authMac(options_.key, AuthStep::kProof, hello_, challenge_major_,
                                       challenge_minor_, *challenge_);
    if (!sameMac(expected, auth.value)) {
      return Status(StatusCode::kUnauthenticated,
                    "the server's proof does not match our key: it holds another key");
    }
    server_proved_ = true;
    return Status::ok();
  }
  return Status(StatusCode::kUnexpectedMessage, "Auth out of order");
}

void ServerLink::poll(int timeout_ms, std::vector<Frame>& received) {
  if (fatal_) return;
  uint64_t now = monotonicNs();
  if (connection_ == nullptr) {
    if (now < next_attempt_ns_) {
      const int wait_ms = static_cast<int>((next_attempt_ns_ - now) / 1000000ull);
      ::poll(nullptr, 0, std::min(timeout_ms, wait_ms));
      return;
    }
    tryConnect();
    if (connection_ == nullptr) return;
  }
  pollfd p{connection_->fd(),
           static_cast<short>(POLLIN | (connection_->wantsWrite() ? POLLOUT : 0)), 0};
  const int rc = ::poll(&p, 1, timeout_ms);
  if (rc > 0 && (p.revents & (POLLIN | POLLHUP | POLLERR))) {
    Status s = connection_->onReadable();
    read_ns_ = monotonicNs();
    while (connection_ != nullptr && connection_->hasFrame()) {
      handle(connection_->takeFrame(), received);
      if (s.isOk() && connection_ != nullptr) s = connection_->readOnIfHeaderWaits();
    }
    if (!s.isOk()) {
      fail(s);
      return;
    }
  }
  if (connection_ == nullptr) return;
  now = monotonicNs();
  if (acked_ && !connection_->wantsWrite() &&
      now - connection_->lastSendNs() >= uint64_t{heartbeat_interval_ms_} * 1000000ull) {
    connection_->sendMessage(Heartbeat{now});
  }
  if (acked_ && agreed_minor_ >= 8) {  // ClockProbe came with 1.8
    if (auto probe = clock_.probeDue(now)) connection_->sendMessage(*probe);
  }
  if (connection_->wantsWrite()) {
    const Status s = connection_->onWritable();
    if (!s.isOk()) {
      fail(s);
      return;
    }
  }
  if (now - connection_->lastReceiveNs() > uint64_t{idle_timeout_ms_} * 1000000ull) {
    fail(Status(StatusCode::kTimeout,
                "heard nothing for " + std::to_string(idle_timeout_ms_) + " ms"));
  }
}

void ServerLink::send(SharedFrame frame) {
  if (connection_ != nullptr && acked_) connection_->send(std::move(frame));
}

void ServerLink::close(const std::string& reason, int timeout_ms) {
  if (connection_ == nullptr) return;
  connection_->sendMessage(Bye{reason});
  connection_->closeGracefully(timeout_ms);
  bytes_out_closed_ += connection_->bytesOut();
  bytes_in_closed_ += connection_->bytesIn();
  dropped_closed_ += connection_->framesDropped();
  connection_.reset();
  acked_ = false;
}

}  // namespace holofuse::protocol
