#include "fusion_server/fusion_server.h"

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "base/shutdown.h"
#include "codec/image_codec.h"
#include "codec/mesh_codec.h"
#include "protocol/clock.h"
#include "protocol/handshake.h"

namespace holofuse::fusion {

using protocol::Frame;
using protocol::MessageType;
using protocol::monotonicNs;

namespace {

// A peer's control messages of one kind (heartbeats, clock probes) that
// come closer together than the floor, more than 10 in a row, close it:
// answering them at any rate would let one peer take the loop.
Status holdToFloor(uint64_t& last_ns, uint32_t& early_run, uint32_t floor_ms, const char* what) {
  const uint64_t now = monotonicNs();
  const bool early = now - last_ns < uint64_t{floor_ms} * 1000000;
  last_ns = now;
  early_run = early ? early_run + 1 : 0;
  if (early_run <= 10) return Status::ok();
  return Status(StatusCode::kTooLarge, std::string(what) + " closer together than " +
                                           std::to_string(floor_ms) + " ms, " +
                                           std::to_string(early_run) + " in a row");
}

// Frames read from one peer per turn of the loop: a flood of tiny messages
// waits in the socket, not in the server's memory.
constexpr size_t kMaxFramesPerTurn = 64;

// Whatever a peer may send before it is admitted: a Hello, an Auth.
constexpr uint32_t kMaxPayloadBeforeAdmission = 256;
// After admission, every message but a pod's PodFrames: Calibration,
// Heartbeat, Bye and types this build does not know.
constexpr uint32_t kMaxControlPayload = 64u << 10;

// The largest PodFrame a pod of this calibration can need: colour (3
// bytes a pixel), mask, feather and depth (2) planes at LZ4's worst case
// (n + n/255 + 16 each), and room for the fields and 1024 stage stamps.
uint32_t podFrameCap(const protocol::Calibration& c, uint32_t max_payload) {
  const uint64_t pixels = uint64_t{c.width} * c.height;
  const uint64_t planes = 7 * pixels + 7 * pixels / 255 + 4 * 16;
  return static_cast<uint32_t>(std::min<uint64_t>(max_payload, planes + (64u << 10)));
}

}  // namespace

FusionServer::FusionServer(ServerOptions options)
    : options_(std::move(options)), pipeline_(options_) {
  options_.fusion.pods_expected = static_cast<uint32_t>(options_.pods);
}

Status FusionServer::start() {
  // The kernel's largest accept queue: a burst of strangers must not fill
  // it before the loop has accepted (and refused) them, or honest peers'
  // connects time out behind them.
  auto listener = protocol::listenTcp(options_.listen, SOMAXCONN);
  if (!listener.isOk()) return listener.status();
  listener_ = std::move(*listener);
  HOLOFUSE_RETURN_IF_ERROR(pipeline_.start());
  if (!options_.port_file.empty()) {
    std::ofstream(options_.port_file) << port() << "\n";
  }
  // The settings a run's numbers depend on, in its log.
  const FusionSettings& f = options_.fusion;
  std::fprintf(stderr,
               "[server] listening on %s:%u for %d pods; voxel %g m (error target %g mm, "
               "refinement %g voxels), meshes %s (Draco %d "
               "bits speed %d), "
               "images to clients %s at LZ4 acceleration %d, LZ4HC level %d; fusion on %d "
               "threads\n",
               options_.listen.host.c_str(), port(), options_.pods, f.hull.voxel_size,
               1000.0 * f.hull_error_target, f.refine.depth_voxels,
               meshCodecName(f.mesh_codec).c_str(), f.draco.position_bits, f.draco.speed,
               imageCodecName(f.image_codec).c_str(), f.lz4_acceleration, f.lz4_hc_level,
               fusionThreads(f));
  return Status::ok();
}

void FusionServer::refuseConnection(protocol::Socket socket, const std::string& name,
                                    const std::string& why) {
  if (refused_connections_++ % 100 == 0) {
    std::fprintf(stderr, "[server] refusing %s: %s (%llu refused so far)\n", name.c_str(),
                 why.c_str(), static_cast<unsigned long long>(refused_connections_));
  }
  // One try at telling it why, without waiting on a peer that may not read.
  protocol::Connection refused(std::move(socket), name);
  refused.sendMessage(
      protocol::ErrorMessage{static_cast<uint16_t>(StatusCode::kTooLarge), "refused: " + why});
  (void)refused.onWritable();
}

bool FusionServer::makeRoom(const std::string& why) {
  // Strangers first (no Hello yet), then claims to be a client; a pending
  // claim to be a pod is the reserve and stays.
  std::optional<size_t> stalest;
  int stalest_rank = 0;
  for (size_t i = 0; i < peers_.size(); ++i) {
    const Peer& peer = peers_[i];
    if (peer.greeted) continue;
    const bool claims_pod = peer.pending && peer.pending->hello.role == protocol::Role::kPod;
    if (claims_pod) continue;
    const int rank = peer.pending ? 1 : 2;
    if (!stalest || rank > stalest_rank ||
        (rank == stalest_rank && peer.accepted_ns < peers_[*stalest].accepted_ns)) {
      stalest = i;
      stalest_rank = rank;
    }
  }
  if (!stalest) return false;
  Peer& evicted = peers_[*stalest];
  if (made_room_++ % 100 == 0) {
    std::fprintf(stderr,
                 "[server] %s: closing %s, the connection longest in its handshake, to make room "
                 "for a newer one (%llu so far)\n",
                 why.c_str(), evicted.connection->peerName().c_str(),
                 static_cast<unsigned long long>(made_room_));
  }
  // One try at telling it why, without waiting on a peer that may not read.
  evicted.connection->sendMessage(
      protocol::ErrorMessage{static_cast<uint16_t>(StatusCode::kTimeout),
                             why + ": closed to make room for a newer connection after " +
                                 std::to_string((monotonicNs() - evicted.accepted_ns) / 1000000) +
                                 " ms without finishing its handshake"});
  (void)evicted.connection->onWritable();
  peers_.erase(peers_.begin() + static_cast<std::ptrdiff_t>(*stalest));
  return true;
}

void FusionServer::limitPodClaims(uint32_t pod) {
  constexpr size_t kClaimsPerPod = 2;
  std::vector<Peer*> claims;
  for (Peer& peer : peers_) {
    if (!peer.greeted && peer.pending && !peer.close_now &&
        peer.pending->hello.role == protocol::Role::kPod && peer.pending->hello.id == pod)
      claims.push_back(&peer);
  }
  if (claims.size() <= kClaimsPerPod) return;
  Peer* oldest = *std::min_element(claims.begin(), claims.end(), [](const Peer* a, const Peer* b) {
    return a->accepted_ns < b->accepted_ns;
  });
  // Closed by the loop (this runs while it walks the peers).
  oldest->close_now =
      Status(StatusCode::kTimeout, "a newer connection claims pod " + std::to_string(pod) +
                                       " too and this one has not answered");
}

void FusionServer::acceptAll() {
  // Bounded per turn: a crowd that connects as fast as we accept does not
  // keep the loop here.
  constexpr int kMostAcceptsPerTurn = 64;
  for (int accepted = 0; accepted < kMostAcceptsPerTurn; ++accepted) {
    std::string name;
    int error = 0;
    protocol::Socket socket = listener_.acceptOne(&name, &error);
    if (!socket.valid()) {
      if (error == EMFILE || error == ENFILE || error == ENOBUFS || error == ENOMEM) {
        // Out of descriptors: a stranger's makes room for the one waiting.
        if (makeRoom(std::string("cannot accept (") + std::strerror(error) + ")")) continue;
        accept_paused_until_ns_ = monotonicNs() + 100'000'000ull;
        if (accept_pauses_++ % 100 == 0) {
          std::fprintf(stderr,
                       "[server] cannot accept (%s) with %zu peers connected: not accepting for "
                       "100 ms (%llu pauses so far)\n",
                       std::strerror(error), peers_.size(),
                       static_cast<unsigned long long>(accept_pauses_));
        }
      }
      return;
    }
    // Caps on connections (SECURITY.md): in all, in the handshake, and in
    // the handshake from one address, so strangers cannot crowd out a rig.
    const std::string address = name.substr(0, name.rfind(':'));
    size_t handshaking = 0, from_address = 0;
    for (const Peer& peer : peers_) {
      if (peer.greeted) continue;
      ++handshaking;
      from_address += peer.connection->address() == address;
    }
    if (from_address >= options_.max_handshaking_per_address) {
      refuseConnection(std::move(socket), name,
                       std::to_string(from_address) + " connections from " + address +
                           " already in their handshake (--max-handshaking-per-address)");
      continue;
    }
    if (peers_.size() >= options_.max_connections &&
        !makeRoom(std::to_string(peers_.size()) + " connections (--max-connections)")) {
      refuseConnection(std::move(socket), name,
                       std::to_string(peers_.size()) + " connections already (--max-connections)");
      continue;
    }
    if (handshaking >= options_.max_handshaking &&
        !makeRoom(std::to_string(handshaking) +
                  " connections in their handshake (--max-handshaking)")) {
      refuseConnection(std::move(socket), name,
                       std::to_string(handshaking) +
                           " connections already in their handshake (--max-handshaking)");
      continue;
    }
    protocol::ConnectionLimits limits;
    limits.max_queued_droppable = options_.client_queue_frames;
    limits.max_payload = std::min(options_.max_payload, kMaxPayloadBeforeAdmission);
    limits.max_queued_bytes = options_.max_peer_buffered_bytes;
    Peer peer;
    peer.connection = std::make_unique<protocol::Connection>(std::move(socket), name, limits);
    peer.connection->setAddress(address);
    peer.serial = next_serial_++;
    peer.accepted_ns = monotonicNs();
    peers_.push_back(std::move(peer));
  }
}

Status FusionServer::handleHello(Peer& peer, const Frame& frame) {
  protocol::Hello hello;
  HOLOFUSE_RETURN_IF_ERROR(protocol::decodeFrame(frame, hello));
  auto ack = protocol::negotiate(hello, options_.max_minor);
  if (!ack.isOk()) return ack.status();
  const std::string who = protocol::identityName(hello.role, hello.id);
  if (hello.role == protocol::Role::kPod && hello.id >= static_cast<uint32_t>(options_.pods)) {
    return Status(StatusCode::kMalformed, "pod id " + std::to_string(hello.id) + " outside 0.." +
                                              std::to_string(options_.pods - 1));
  }
  if (!options_.keys) return admit(peer, hello, *ack);
  if (!capabilitiesOf(ack->minor).authenticates) {
    return Status(StatusCode::kUnauthenticated,
                  who + " speaks protocol 1." + std::to_string(ack->minor) +
                      ", which has no authentication; this server requires it (1.4 or "
                      "later, or a server started with --no-auth)");
  }
  const std::vector<uint8_t>* key = options_.keys->keyFor(hello.role, hello.id);
  if (key == nullptr) {
    return Status(StatusCode::kUnauthenticated, "no key for " + who + " in the server's key file");
  }
  Peer::PendingAuth pending{hello, *ack, protocol::randomAuthBytes(), key};
  protocol::Auth challenge;
  challenge.step = protocol::AuthStep::kChallenge;
  challenge.value = pending.challenge;
  // Under the agreed version, which both MACs cover.
  peer.connection->send(std::make_shared<const protocol::OutgoingFrame>(
      protocol::encodeOutgoing(challenge, protocol::nextSequence(), nullptr, ack->minor)));
  peer.pending = std::move(pending);
  if (hello.role == protocol::Role::kPod) limitPodClaims(hello.id);
  return Status::ok();
}

Status FusionServer::handleAuthAnswer(Peer& peer, const Frame& frame) {
  protocol::Auth answer;
  HOLOFUSE_RETURN_IF_ERROR(protocol::decodeFrame(frame, answer));
  const Peer::PendingAuth pending = *peer.pending;
  peer.pending.reset();
  const std::string who = protocol::identityName(pending.hello.role, pending.hello.id);
  const auto expected =
      protocol::authMac(*pending.key, protocol::AuthStep::kResponse, pending.hello,
                        pending.ack.major, pending.ack.minor, pending.challenge);
  if (answer.step != protocol::AuthStep::kResponse || !protocol::sameMac(expected, answer.value)) {
    return Status(StatusCode::kUnauthenticated,
                  "authentication failed for " + who +
                      ": the answer does not match its key (a wrong key, or an answer "
                      "replayed from another connection)");
  }
  protocol::Auth proof;
  proof.step = protocol::AuthStep::kProof;
  proof.value = protocol::authMac(*pending.key, protocol::AuthStep::kProof, pending.hello,
                                  pending.ack.major, pending.ack.minor, pending.challenge);
  peer.connection->send(std::make_shared<const protocol::OutgoingFrame>(
      protocol::encodeOutgoing(proof, protocol::nextSequence(), nullptr, pending.ack.minor)));
  return admit(peer, pending.hello, pending.ack);
}

Status FusionServer::admit(Peer& peer, const protocol::Hello& hello, protocol::HelloAck ack) {
  if (hello.role == protocol::Role::kPod) {
    for (Peer& other : peers_) {
      if (&other == &peer || !other.greeted || other.role != protocol::Role::kPod ||
          other.id != hello.id || other.replaced)
        continue;
      if (!options_.keys) {
        // Without keys anyone can claim any id: a live pod is never
        // replaced, and a pod whose old link is half open gets in once
        // that link's idle timeout closes it.
        return Status(StatusCode::kUnexpectedMessage,
                      "pod " + std::to_string(hello.id) + " is already connected (" +
                          other.connection->peerName() +
                          "); without authentication a live pod is not replaced");
      }
      // It proved it holds the pod's key: a reconnect of the pod itself,
      // whose old connection may still be half open.
      std::fprintf(stderr, "[server] pod %u authenticated again; dropping its old connection %s\n",
                   hello.id, other.connection->peerName().c_str());
      other.replaced = true;
    }
  }
  ack.session_id = next_session_++;
  ack.server_time_ns = monotonicNs();
  ack.heartbeat_interval_ms = options_.heartbeat_interval_ms;
  ack.idle_timeout_ms = options_.idle_timeout_ms;
  peer.greeted = true;
  peer.budget = PeerBudget(options_.budget, monotonicNs());
  peer.connection->setMaxPayload(std::min(options_.max_payload, kMaxControlPayload));
  if (hello.role == protocol::Role::kPod) pipeline_.podJoined(hello.id);
  peer.role = hello.role;
  peer.id = hello.id;
  peer.caps = capabilitiesOf(ack.minor, hello.role, hello.capabilities);
  peer.clock = protocol::ClockSync(options_.clock);
  setLayersTaken(peer, hello.capabilities);
  peer.connection->setPeerName((hello.role == protocol::Role::kPod ? "pod " : "client ") +
                               std::to_string(hello.id) + " (" + peer.connection->peerName() + ")");
  peer.connection->sendMessage(ack);
  std::fprintf(stderr, "[server] %s joined, protocol %u.%u%s%s\n",
               peer.connection->peerName().c_str(), ack.major, ack.minor,
               options_.keys ? ", authenticated" : "", layersTakenNote(peer).c_str());
  if (peer.role == protocol::Role::kClient) pipeline_.welcomeClient(peer);
  return Status::ok();
}

Status FusionServer::handleClockProbe(Peer& peer, const Frame& frame) {
  protocol::ClockProbe probe;
  HOLOFUSE_RETURN_IF_ERROR(protocol::decodeFrame(frame, probe));
  if (probe.step == protocol::ProbeStep::kRequest) {
    // Answered at once, like a heartbeat, and held to the same floor.
    HOLOFUSE_RETURN_IF_ERROR(holdToFloor(peer.last_probe_ns, peer.early_probes,
                                         options_.min_heartbeat_interval_ms, "clock probes"));
    const uint64_t now = monotonicNs();
    peer.connection->sendMessage(protocol::ClockSync::answer(probe, peer.read_ns, now));
    return Status::ok();
  }
  const Status taken = peer.clock.onReply(probe, peer.read_ns);
  const std::string& name = peer.connection->peerName();
  if (!taken.isOk()) {
    // The estimate keeps its good samples; the peer keeps being served, and
    // the log is not flooded.
    if (peer.bad_probe_answers++ % 100 == 0)
      std::fprintf(stderr, "[server] ignored clock probe answer %llu from %s: %s\n",
                   static_cast<unsigned long long>(peer.bad_probe_answers), name.c_str(),
                   taken.message().c_str());
    return Status::ok();
  }
  if (!peer.clock_told && peer.clock.samples() >= options_.clock.burst) {
    peer.clock_told = true;
    std::fprintf(stderr, "[server] %s's clock against ours: %s (round trip %.3f ms)\n",
                 name.c_str(), peer.clock.describe().c_str(),
                 static_cast<double>(peer.clock.roundTripNs()) / 1e6);
  }
  const uint64_t threshold_ns = static_cast<uint64_t>(options_.clock_drift_warn_ms * 1e6);
  if (!peer.drift_warned && peer.clock.drifted(threshold_ns)) {
    peer.drift_warned = true;
    std::fprintf(stderr,
                 "[server] warning: %s's clock moved %+.3f ms since its first estimate, more "
                 "than --clock-drift-warn-ms %g beyond the estimates' uncertainty: discipline "
                 "its host's clock (chrony or linuxptp, docs/runbook.md)\n",
                 name.c_str(), static_cast<double>(peer.clock.driftNs()) / 1e6,
                 options_.clock_drift_warn_ms);
  }
  return Status::ok();
}

Status FusionServer::handleFrameRequest(Peer& peer, const Frame& frame) {
  if (peer.role != protocol::Role::kClient)
    return Status(StatusCode::kUnexpectedMessage, "FrameRequest from a pod");
  protocol::FrameRequest request;
  HOLOFUSE_RETURN_IF_ERROR(protocol::decodeFrame(frame, request));
  // Only a client that said it would ask (Hello, since 1.9) is paced; any
  // other is sent every frame (SPEC.md section 6) and its request ignored.
  if (peer.caps.asks_for_frames) peer.frames_through = request.frames_through;
  if (peer.caps.changes_layers && request.layer_capabilities) {
    const std::string before = layersTakenNote(peer);
    setLayersTaken(peer, *request.layer_capabilities);
    if (const std::string note = layersTakenNote(peer); note != before) {
      // Its stream starts again at a key frame (asked for as the next
      // group is submitted).
      peer.layer_video_in_step = false;
      std::fprintf(stderr, "[server] %s takes from the next frame: %s\n",
                   peer.connection->peerName().c_str(),
                   note.empty() ? "camera images" : note.c_str() + 2);
    }
  }
  return Status::ok();
}

void FusionServer::setLayersTaken(Peer& peer, uint64_t capability_bits) {
  const PeerCapabilities asked = capabilitiesOf(peer.caps.minor, peer.role, capability_bits);
  peer.caps.layers = asked.layers;
  peer.caps.layer_video = asked.layer_video;
  // The layers are laid out on the mesh as the configured codec gives it;
  // a client that decodes only Draco gets Draco's, whose positions differ.
  const bool layers_fit =
      peer.caps.any_mesh_codec || options_.fusion.mesh_codec == protocol::MeshCodec::kDraco;
  peer.wants_layers = peer.caps.layers && layers_fit;
  peer.wants_layer_video = peer.wants_layers && peer.caps.layer_video &&
                           isVideoCodec(options_.fusion.layers.video.codec);
}

std::string FusionServer::layersTakenNote(const Peer& peer) {
  return peer.wants_layer_video ? ", texture layers as video"
         : peer.wants_layers    ? ", texture layers"
         : peer.caps.layers     ? ", no texture layers (they are laid out on meshes it does not "
                                  "decode: --mesh-codec is not draco and it speaks 1.6 or older)"
                                : "";
}

void FusionServer::measureRigPixels() {
  std::vector<uint64_t> pixels;
  for (const Peer& other : peers_) {
    if (other.role != protocol::Role::kPod || !other.calibrated || other.replaced) continue;
    const Camera& camera = cameras_.at(other.id);
    pixels.push_back(uint64_t{camera.width} * camera.height);
  }
  std::sort(pixels.begin(), pixels.end());
  // The lower median: with two pods, the smaller one is the rig's.
  rig_pixels_ = {pixels.empty() ? 0 : pixels[(pixels.size() - 1) / 2], pixels.size()};
}

Status FusionServer::podCostTooHigh(const Peer& peer) const {
  if (peer.role != protocol::Role::kPod || !peer.calibrated) return Status::ok();
  const auto [median, pods] = rig_pixels_;
  const Camera& camera = cameras_.at(peer.id);
  const uint64_t own = uint64_t{camera.width} * camera.height;
  if (static_cast<double>(own) <= options_.max_pod_cost_ratio * static_cast<double>(median))
    return Status::ok();
  char numbers[160];
  std::snprintf(numbers, sizeof(numbers),
                "%ux%u (%llu pixels), cost %.1f times the rig's median pod (%llu pixels, of %zu "
                "pods); a pod may cost at most --max-pod-cost-ratio %g times it",
                camera.width, camera.height, static_cast<unsigned long long>(own),
                static_cast<double>(own) / static_cast<double>(median),
                static_cast<unsigned long long>(median), pods, options_.max_pod_cost_ratio);
  return Status(StatusCode::kTooLarge, std::string("its images, ") + numbers);
}

Status FusionServer::standing(const Peer& peer, uint64_t now_ns) const {
  if (peer.close_now) return *peer.close_now;
  HOLOFUSE_RETURN_IF_ERROR(offClockTooLong(peer, now_ns));
  // A pod that joined first, before the rig's others showed its size is
  // far above theirs.
  HOLOFUSE_RETURN_IF_ERROR(podCostTooHigh(peer));
  const auto over = peer.budget.overSince();
  if (!peer.greeted || !over || now_ns - *over <= uint64_t{options_.over_budget_close_ms} * 1000000)
    return Status::ok();
  return Status(StatusCode::kTooLarge,
                "sent " + peer.budget.describeOver() + ", over its budget for " +
                    std::to_string((now_ns - *over) / 1000000) + " ms (--over-budget-close-ms " +
                    std::to_string(options_.over_budget_close_ms) + ")");
}

Status FusionServer::offClockTooLong(const Peer& peer, uint64_t now_ns) const {
  if (peer.role != protocol::Role::kPod || !peer.greeted) return Status::ok();
  const PodClock* clock = pipeline_.clockOf(peer.id);
  if (clock == nullptr || !clock->off_since_ns) return Status::ok();
  const uint64_t off_ns = now_ns - *clock->off_since_ns;
  if (off_ns <= uint64_t{options_.off_clock_close_ms} * 1000000) return Status::ok();
  return Status(StatusCode::kMalformed,
                "its frame ids have been off the rig's clock for " +
                    std::to_string(off_ns / 1000000) + " ms (--off-clock-close-ms " +
                    std::to_string(options_.off_clock_close_ms) + "): its latest, " +
                    std::to_string(clock->latest_id) + ", is " + describeOffset(*clock) +
                    "; is its host's clock right?");
}

void FusionServer::enforceBufferedBytes() {
  size_t total = 0, most = 0, holder = 0;
  for (size_t i = 0; i < peers_.size(); ++i) {
    const size_t bytes = peers_[i].connection->bufferedBytes();
    total += bytes;
    if (bytes > most) most = bytes, holder = i;
  }
  if (total <= options_.max_buffered_bytes) return;
  closePeer(holder, Status(StatusCode::kTooLarge,
                           "the server's buffers are full (" + std::to_string(total >> 20) +
                               " MiB of --max-buffered-bytes " +
                               std::to_string(options_.max_buffered_bytes >> 20) +
                               " MiB) and this peer holds the most, " + std::to_string(most >> 20) +
                               " MiB"));
}

Status FusionServer::handleInbox(Peer& peer, Status status) {
  for (;;) {
    std::optional<Frame> next;
    if (peer.held) {
      next = std::move(peer.held);
      peer.held.reset();
    } else if (peer.connection->hasFrame()) {
      next = peer.connection->takeFrame();
    } else {
      return status;
    }
    // A PodFrame is charged its pixels against the rig's median pod's.
    double cost = 1.0;
    if (peer.calibrated && next->header.type == static_cast<uint16_t>(MessageType::kPodFrame)) {
      const Camera& camera = cameras_.at(peer.id);
      const uint64_t median = rig_pixels_.first;
      if (median > 0) cost = static_cast<double>(camera.width) * camera.height / median;
    }
    if (peer.greeted && !peer.budget.take(next->header.type, monotonicNs(), cost)) {
      peer.held = std::move(next);
      peer.paused_until_ns = peer.budget.resumeAt();
      return status;
    }
    const Status handled = handle(peer, std::move(*next));
    if (!handled.isOk()) return handled;
    // A Calibration raises its pod's PodFrame cap for a header held back.
    if (status.isOk())
      status = peer.connection->readOnIfHeaderWaits(options_.read_budget_bytes, kMaxFramesPerTurn);
  }
}

Status FusionServer::handle(Peer& peer, Frame frame) {
  const auto type = static_cast<MessageType>(frame.header.type);
  if (!peer.greeted && peer.pending) {
    if (type == MessageType::kBye) {
      protocol::Bye bye;
      (void)protocol::decodeFrame(frame, bye);
      return Status(StatusCode::kUnauthenticated,
                    protocol::identityName(peer.pending->hello.role, peer.pending->hello.id) +
                        " gave up authenticating: " + bye.reason);
    }
    if (type != MessageType::kAuth) {
      return Status(StatusCode::kUnauthenticated,
                    std::string("expected the answer to our challenge, got ") +
                        protocol::messageTypeName(frame.header.type));
    }
    return handleAuthAnswer(peer, frame);
  }
  if (!peer.greeted) {
    if (type != MessageType::kHello) {
      return Status(
          StatusCode::kUnexpectedMessage,
          std::string("expected Hello first, got ") + protocol::messageTypeName(frame.header.type));
    }
    return handleHello(peer, frame);
  }
  switch (type) {
    case MessageType::kHeartbeat:
      return holdToFloor(peer.last_heartbeat_ns, peer.early_heartbeats,
                         options_.min_heartbeat_interval_ms, "heartbeats");
    case MessageType::kBye: {
      protocol::Bye bye;
      (void)protocol::decodeFrame(frame, bye);
      return Status(StatusCode::kClosed, "said bye: " + bye.reason);
    }
    case MessageType::kClockProbe:
      return handleClockProbe(peer, frame);
    case MessageType::kFrameRequest:
      return handleFrameRequest(peer, frame);
    case MessageType::kCalibration: {
      if (peer.role != protocol::Role::kPod)
        return Status(StatusCode::kUnexpectedMessage, "Calibration from a client");
      protocol::Calibration calibration;
      HOLOFUSE_RETURN_IF_ERROR(protocol::decodeFrame(frame, calibration));
      if (calibration.width > options_.max_image_side ||
          calibration.height > options_.max_image_side) {
        return Status(StatusCode::kTooLarge, "calibration of pod " + std::to_string(peer.id) +
                                                 ": " + std::to_string(calibration.width) + "x" +
                                                 std::to_string(calibration.height) +
                                                 " is above --max-image-side " +
                                                 std::to_string(options_.max_image_side));
      }
      if (calibration.camera_id != peer.id) {
        return Status(StatusCode::kMalformed,
                      "field 'calibration.camera_id': " + std::to_string(calibration.camera_id) +
                          " from pod " + std::to_string(peer.id));
      }
      cameras_[calibration.camera_id] = fromCalibration(calibration);
      peer.calibrated = true;
      measureRigPixels();
      // Within --max-image-side, but far above the rig's pods: refused
      // before anything of its size is read or decoded.
      HOLOFUSE_RETURN_IF_ERROR(podCostTooHigh(peer));
      peer.connection->setTypeCap(MessageType::kPodFrame,
                                  podFrameCap(calibration, options_.max_payload));
      pipeline_.relayCalibration(calibration.camera_id, frame, peers_);
      return Status::ok();
    }
    case MessageType::kPodFrame:
      if (peer.role != protocol::Role::kPod)
        return Status(StatusCode::kUnexpectedMessage, "PodFrame from a client");
      if (!cameras_.count(peer.id))
        return Status(StatusCode::kUnexpectedMessage, "PodFrame before Calibration");
      return pipeline_.podFrame(peer, cameras_.at(peer.id), std::move(frame));
    case MessageType::kHello:
      return Status(StatusCode::kUnexpectedMessage, "second Hello");
    default:
      // Unknown or not-for-the-server types are skipped (forward compatibility).
      return Status::ok();
  }
}

void FusionServer::closePeer(size_t index, const Status& why) {
  Peer& peer = peers_[index];
  if (peer.greeted && peer.role == protocol::Role::kPod && !peer.replaced) {
    pipeline_.podLeft(peer.id);
  }
  if (why.code() == StatusCode::kClosed) {
    std::fprintf(stderr, "[server] %s left (%s)\n", peer.connection->peerName().c_str(),
                 why.message().c_str());
  } else {
    std::fprintf(stderr, "[server] closing %s: %s\n", peer.connection->peerName().c_str(),
                 why.toString().c_str());
    if (why.code() != StatusCode::kIoError && why.code() != StatusCode::kTimeout) {
      peer.connection->sendMessage(
          protocol::ErrorMessage{static_cast<uint16_t>(why.code()), why.message()});
      peer.connection->drain(50);
    }
  }
  const bool calibrated_pod = peer.calibrated;
  peers_.erase(peers_.begin() + static_cast<std::ptrdiff_t>(index));
  if (calibrated_pod) measureRigPixels();
}

int FusionServer::run() {
  std::string bye_reason = "server shutting down";
  while (!stopRequested()) {
    if (!options_.health_file.empty() && monotonicNs() - health_written_ns_ >= 1'000'000'000ull)
      writeHealth("serving");
    if (options_.exit_when_pods_done && pipeline_.podsDone(peers_)) {
      pipeline_.drainWake();
      pipeline_.fanOut(peers_);
      if (pipeline_.podsDone(peers_)) {
        std::fprintf(
            stderr,
            "[server] every pod has left and its frames are fused and delivered: stopping\n");
        bye_reason = "every pod has left and its frames are delivered";
        break;
      }
    }
    std::vector<pollfd> fds;
    const bool accepting = monotonicNs() >= accept_paused_until_ns_;
    fds.push_back({listener_.fd(), static_cast<short>(accepting ? POLLIN : 0), 0});
    fds.push_back({pipeline_.wakeFd(), POLLIN, 0});
    std::vector<bool> reading;
    const uint64_t polled_ns = monotonicNs();
    std::optional<uint64_t> wake_at = pipeline_.nextDeadline();
    for (const auto& peer : peers_) {
      // A peer over its budget is not read until it may send again.
      const bool paused = peer.paused_until_ns > polled_ns;
      if (paused) wake_at = std::min(wake_at.value_or(UINT64_MAX), peer.paused_until_ns);
      reading.push_back(!paused && pipeline_.readable(peer, peers_));
      const bool writing = peer.connection->wantsWrite();
      // Left out while paused with nothing to write: a peer that hung up
      // would wake poll at once, every turn, until then.
      fds.push_back({paused && !writing ? -1 : peer.connection->fd(),
                     static_cast<short>((reading.back() ? POLLIN : 0) | (writing ? POLLOUT : 0)),
                     0});
    }
    int timeout_ms = 100;
    if (wake_at) {
      timeout_ms =
          *wake_at <= polled_ns
              ? 0
              : std::min<int>(timeout_ms, static_cast<int>((*wake_at - polled_ns) / 1000000) + 1);
    }
    ::poll(fds.data(), fds.size(), timeout_ms);
    const size_t polled = fds.size() - 2;
    for (size_t i = polled; i-- > 0;) {
      Peer& peer = peers_[i];
      const short revents = fds[i + 2].revents;
      Status status = Status::ok();
      const bool resting = peer.paused_until_ns > monotonicNs();
      const bool woke = (revents & (POLLIN | POLLHUP | POLLERR)) != 0;
      if (!resting && (woke || peer.held || peer.connection->hasFrame())) {
        if (woke) {
          status = peer.connection->onReadable(options_.read_budget_bytes, kMaxFramesPerTurn);
          peer.read_ns = monotonicNs();
        }
        status = handleInbox(peer, status);
      }
      const uint64_t now = monotonicNs();
      // A pod held back by backpressure is silent because we do not read it.
      if (status.isOk() && reading[i] &&
          now - peer.connection->lastReceiveNs() > uint64_t{options_.idle_timeout_ms} * 1000000) {
        status = Status(StatusCode::kTimeout,
                        "heard nothing for " + std::to_string(options_.idle_timeout_ms) + " ms");
      }
      if (status.isOk() && !peer.greeted &&
          now - peer.accepted_ns > uint64_t{options_.handshake_timeout_ms} * 1000000) {
        status = Status(StatusCode::kTimeout, "no handshake within " +
                                                  std::to_string(options_.handshake_timeout_ms) +
                                                  " ms of connecting");
      }
      if (status.isOk() && peer.greeted && !peer.connection->wantsWrite() &&
          now - peer.connection->lastSendNs() >
              uint64_t{options_.heartbeat_interval_ms} * 1000000) {
        peer.connection->sendMessage(protocol::Heartbeat{now});
      }
      if (status.isOk() && peer.greeted && peer.caps.clock_probes) {
        if (auto probe = peer.clock.probeDue(now)) peer.connection->sendMessage(*probe);
      }
      if (status.isOk()) status = standing(peer, now);
      if (status.isOk() && peer.replaced) {
        status = Status(StatusCode::kClosed, "replaced by a newer connection of the same pod");
      }
      if (!status.isOk()) closePeer(i, status);
    }
    // After the peers polled above are handled (fds follows peers_ by
    // index): making room may close one. Peers accepted now are polled next
    // turn.
    if (fds[0].revents & POLLIN) acceptAll();
    if (fds[1].revents & POLLIN) pipeline_.drainWake();
    for (const FramePipeline::Refused& refused : pipeline_.takeDecodedFrames()) {
      const auto sender = std::find_if(peers_.begin(), peers_.end(), [&](const Peer& peer) {
        return peer.serial == refused.connection;
      });
      if (sender != peers_.end())
        closePeer(static_cast<size_t>(sender - peers_.begin()), refused.why);
    }
    pipeline_.dispatchReadyGroups(peers_);
    pipeline_.fanOut(peers_);
    enforceBufferedBytes();
    pipeline_.reportRecordingProgress();
    for (size_t i = peers_.size(); i-- > 0;) {
      if (!peers_[i].connection->wantsWrite()) continue;
      const Status s = peers_[i].connection->onWritable();
      if (!s.isOk()) closePeer(i, s);
    }
  }
  for (auto& peer : peers_) {
    peer.connection->sendMessage(protocol::Bye{bye_reason});
    peer.connection->closeGracefully(options_.exit_when_pods_done ? 5000 : 100);
  }
  pipeline_.closeRecording();
  if (!options_.health_file.empty()) writeHealth("stopped");
  std::fprintf(stderr, "[server] stopped after %s\n", pipeline_.summary().c_str());
  return 0;
}

void FusionServer::writeHealth(const char* state) {
  health_written_ns_ = monotonicNs();
  size_t pods = 0, clients = 0;
  for (const Peer& peer : peers_) {
    if (!peer.greeted) continue;
    (peer.role == protocol::Role::kPod ? pods : clients) += 1;
  }
  const std::string aside = options_.health_file + ".tmp";
  {
    std::ofstream out(aside);
    out << "{\"state\": \"" << state << "\", \"port\": " << port() << ", \"pods\": " << pods
        << ", \"pods_expected\": " << options_.pods << ", \"clients\": " << clients
        << ", \"groups_fused\": " << pipeline_.groupsFused()
        << ", \"groups_not_asked_for\": " << pipeline_.groupsNotAskedFor()
        << ", \"groups_fusing\": " << pipeline_.groupsFusing() << "}\n";
  }
  if (std::rename(aside.c_str(), options_.health_file.c_str()) != 0 && !health_failed_) {
    health_failed_ = true;
    std::fprintf(stderr, "[server] cannot write the health file %s: %s\n",
                 options_.health_file.c_str(), std::strerror(errno));
  }
}

StatusOr<std::string> checkHealth(const std::string& path, uint32_t max_age_ms) {
  std::error_code error;
  const auto written = std::filesystem::last_write_time(path, error);
  if (error) return Status(StatusCode::kIoError, path + ": " + error.message());
  const auto age = std::chrono::duration_cast<std::chrono::milliseconds>(
      std::filesystem::file_time_type::clock::now() - written);
  if (age.count() > static_cast<int64_t>(max_age_ms)) {
    return Status(StatusCode::kTimeout,
                  path + " was last rewritten " + std::to_string(age.count()) + " ms ago (limit " +
                      std::to_string(max_age_ms) + " ms): the server is stuck or gone");
  }
  std::ifstream in(path);
  const auto health = nlohmann::json::parse(in, nullptr, false);
  if (health.is_discarded() || !health.contains("state") || !health["state"].is_string())
    return Status(StatusCode::kMalformed, path + " is not a server's health file");
  const std::string state = health["state"].get<std::string>();
  if (state != "serving") return Status(StatusCode::kClosed, "the server is " + state);
  return "serving on port " + health.value("port", nlohmann::json(0)).dump() + ": " +
         health.value("pods", nlohmann::json(0)).dump() + " of " +
         health.value("pods_expected", nlohmann::json(0)).dump() + " pods, " +
         health.value("clients", nlohmann::json(0)).dump() + " clients, " +
         health.value("groups_fused", nlohmann::json(0)).dump() + " groups fused";
}

}  // namespace holofuse::fusion
