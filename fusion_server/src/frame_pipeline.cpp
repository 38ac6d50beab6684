#include "fusion_server/frame_pipeline.h"

#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "protocol/clock.h"

namespace holofuse::fusion {

using protocol::Frame;
using protocol::monotonicNs;

FramePipeline::FramePipeline(const ServerOptions& options)
    : options_(options),
      sync_(options.lossless ? FrameSync::lossless(options.max_id_skew)
                             : FrameSync(static_cast<uint64_t>(options.sync_deadline_ms * 1e6),
                                         options.max_id_skew)) {}

FramePipeline::~FramePipeline() {
  decoder_.reset();
  worker_.reset();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

Status FramePipeline::start() {
  wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd_ < 0) return Status(StatusCode::kIoError, "eventfd: cannot wake the loop");
  if (!options_.record_dir.empty()) {
    auto recorder = dataset::Recorder::open(options_.record_dir, options_.record_fused);
    if (!recorder.isOk()) return recorder.status();
    recorder_ = std::move(*recorder);
  }
  worker_ = std::make_unique<FusionWorker>(options_.fusion, wake_fd_, options_.lossless);
  decoder_ = std::make_unique<PodDecoder>(options_.decode_threads, wake_fd_);
  return Status::ok();
}

void FramePipeline::drainWake() {
  // The decoder and the worker both write the one descriptor.
  uint64_t counter = 0;
  while (::read(wake_fd_, &counter, sizeof(counter)) > 0) {
  }
}

void FramePipeline::podJoined(uint32_t pod) {
  departed_pods_.erase(pod);
  streaming_.erase(pod);
  // A pod back on a new connection may send from another clock: its first
  // transit starts afresh rather than counting the offset as jitter, and
  // its frame ids are judged afresh too.
  if (auto known = pod_arrivals_.find(pod); known != pod_arrivals_.end()) known->second.restart();
  sync_.forgetPod(pod);
}

void FramePipeline::podLeft(uint32_t pod) {
  departed_pods_.insert(pod);
  // Its vote on the rig's clock leaves with it (frame_sync.h).
  sync_.forgetPod(pod);
}

void FramePipeline::relayCalibration(uint32_t camera_id, const Frame& frame,
                                     std::vector<Peer>& peers) {
  if (recorder_)
    recorder_->recordPodMessage(dataset::RecordKind::kCalibration, camera_id, 0, frame);
  auto bytes = std::make_shared<const protocol::OutgoingFrame>(frame.bytes);
  calibration_frames_[camera_id] = bytes;
  for (auto& other : peers) {
    if (other.isClient()) other.connection->send(bytes);
  }
}

void FramePipeline::welcomeClient(Peer& client) const {
  for (const auto& [id, bytes] : calibration_frames_) client.connection->send(bytes);
}

void FramePipeline::reportRecordingProgress() {
  if (recorder_) recorder_->maybeReportProgress(monotonicNs());
}

void FramePipeline::closeRecording() {
  if (recorder_) recorder_->close();
}

std::string FramePipeline::summary() const {
  const FusionWorker::Overlap overlap = worker_->overlap();
  char text[300];
  std::snprintf(text, sizeof(text),
                "fusing %llu groups (%llu late pod frames, %llu groups dropped, %llu not fused: "
                "no client asked for them; %llu of %llu begun before the one before was done, "
                "on %d fusion thread%s)",
                static_cast<unsigned long long>(groups_fused_),
                static_cast<unsigned long long>(sync_.lateFrames()),
                static_cast<unsigned long long>(sync_.overflowedGroups() + worker_->replacedJobs()),
                static_cast<unsigned long long>(groups_not_asked_for_),
                static_cast<unsigned long long>(overlap.at_once),
                static_cast<unsigned long long>(overlap.pairs), worker_->threads(),
                worker_->threads() == 1 ? "" : "s");
  return text;
}

std::set<uint32_t> FramePipeline::expectedPods() const {
  // Every configured pod is waited for (up to the sync deadline) until it
  // has been seen to leave: a pod still starting up gets the deadline, a
  // pod that left stalls nothing.
  std::set<uint32_t> ids;
  for (uint32_t id = 0; id < static_cast<uint32_t>(options_.pods); ++id) {
    if (departed_pods_.count(id) == 0) ids.insert(id);
  }
  // A pod that left with frames still decoding is waited for until they
  // are in: its last frames are fused like the others.
  for (uint32_t id : decoder_->podsInFlight()) ids.insert(id);
  return ids;
}

Status FramePipeline::podFrame(const Peer& peer, const Camera& camera, Frame frame) {
  // Stamped before the decoding, which starts the server_decode stage here
  // (waiting for a decoder thread is part of it).
  // A pod that answers clock probes has its times placed on ours from its
  // first answer on (an older pod is taken to share our clock).
  std::optional<int64_t> offset = 0;
  if (peer.caps.clock_probes)
    offset = peer.clock.known() ? std::optional(peer.clock.offsetNs()) : std::nullopt;
  const uint64_t uncertainty = offset && peer.clock.known() ? peer.clock.uncertaintyNs() : 0;
  PodDecodeJob job{peer.serial,   peer.id, std::move(frame), camera,
                   monotonicNs(), offset,  uncertainty};
  decoder_->submit(std::move(job));
  return Status::ok();
}

std::vector<FramePipeline::Refused> FramePipeline::takeDecodedFrames() {
  std::vector<Refused> refused;
  for (DecodedPodFrame& decoded : decoder_->takeDecoded()) {
    if (decoded.status.isOk()) {
      syncDecoded(std::move(decoded.frame), decoded.pod, decoded.frame_id,
                  std::move(decoded.images));
      continue;
    }
    // Refused as malformed: its connection is closed (if still open), and
    // it counts for nothing.
    refused.push_back({decoded.connection, decoded.status});
  }
  return refused;
}

void FramePipeline::syncDecoded(Frame frame, uint32_t pod, uint64_t frame_id, PodImages images) {
  const double sent_ms = static_cast<double>(images.pod_sent_ns) / 1e6;
  const double arrival_ms = static_cast<double>(images.arrival_ns) / 1e6;
  // The group waits from the first frame decoded: its decoding is
  // server_decode's, and the latency budget must not count it twice.
  const FrameSync::Added added = sync_.add(frame_id, std::move(images), monotonicNs());
  if (added == FrameSync::Added::kOffClock) {
    // Another clock than the rig's: the frame is dropped, the pod kept
    // until it has been off for off_clock_close_ms (frame_sync.h).
    tellOffClock(pod, frame_id);
    return;
  }
  // Every frame a pod sends counts for its jitter, also one that arrives too
  // late to be fused: the link's behaviour, not the fusion's. A frame refused
  // as malformed does not count.
  if (sent_ms > 0) pod_arrivals_[pod].add(sent_ms, arrival_ms);
  if (streaming_.insert(pod).second) {
    std::fprintf(stderr, "[server] pod %u's first frame is in (id %llu)\n", pod,
                 static_cast<unsigned long long>(frame_id));
  }
  // What the fusion takes, as it arrived (a late frame is not fused, so a
  // replay must not fuse it either).
  if (added == FrameSync::Added::kAccepted && recorder_) {
    recorder_->recordPodMessage(dataset::RecordKind::kPodFrame, pod, frame_id, frame);
  }
}

void FramePipeline::tellOffClock(uint32_t pod, uint64_t frame_id) {
  const PodClock* clock = sync_.clockOf(pod);
  if (clock == nullptr || !clock->off_since_ns) return;
  // The first frame of a run off the clock, and every 100th in all.
  if (*clock->off_since_ns != clock->heard_ns && clock->off_frames % 100 != 0) return;
  std::fprintf(stderr,
               "[server] pod %u is off the rig's clock: frame id %llu is %s; its frames are "
               "dropped and it is not waited for (%llu so far), and it is closed if it stays off "
               "for %u ms (does it run on another clock?)\n",
               pod, static_cast<unsigned long long>(frame_id), describeOffset(*clock).c_str(),
               static_cast<unsigned long long>(clock->off_frames), options_.off_clock_close_ms);
}

bool FramePipeline::fusingWhenAsked(const std::vector<Peer>& peers) const {
  if (!options_.fuse_when_asked || options_.lossless || options_.record_fused) return false;
  bool clients = false;
  for (const Peer& p : peers) {
    if (!p.isClient()) continue;
    if (!p.caps.asks_for_frames) return false;
    clients = true;
  }
  return clients;
}

bool FramePipeline::aClientWaitsForAFrame(const std::vector<Peer>& peers) const {
  // Groups submitted and not yet sent out: each goes to every client that
  // still asks for a frame then.
  const uint64_t fusing = worker_->jobsNotTaken();
  for (const Peer& p : peers) {
    if (p.isClient() && p.framesOwed() > fusing) return true;
  }
  return false;
}

void FramePipeline::dispatchReadyGroups(const std::vector<Peer>& peers) {
  const bool when_asked = fusingWhenAsked(peers);
  std::vector<FrameGroup> ready = sync_.takeReady(expectedPods(), monotonicNs());
  // No one paces any more (a client that does not ask joined, or the last
  // that asked left): a group held goes first, unless newer ones are ready
  // (a waiting job gives way to a newer one; frames never go backwards).
  if (held_group_ && !when_asked) {
    const bool newer = std::any_of(ready.begin(), ready.end(),
                                   [](const FrameGroup& g) { return !g.pods.empty(); });
    if (newer) {
      ++groups_not_asked_for_;
    } else {
      submitGroup(std::move(*held_group_), peers);
    }
    held_group_.reset();
  }
  for (auto& group : ready) {
    if (group.pods.empty()) continue;
    if (!when_asked) {
      submitGroup(std::move(group), peers);
      continue;
    }
    if (held_group_) ++groups_not_asked_for_;
    held_group_ = std::move(group);
  }
  // The held group goes as soon as a client asks (it is at most one pod
  // frame interval old while the pods send), or when no one paces.
  if (held_group_ && (!when_asked || aClientWaitsForAFrame(peers))) {
    submitGroup(std::move(*held_group_), peers);
    held_group_.reset();
  }
}

void FramePipeline::submitGroup(FrameGroup group, const std::vector<Peer>& peers) {
  // Layers are built only while a client that asked for them is here,
  // coded as each such client decodes them; the mesh in Draco too while
  // a client before 1.7 is.
  FusionWorker::LayersWanted wanted;
  GroupJob job;
  for (const Peer& p : peers) {
    if (!p.isClient()) continue;
    job.draco_for_older = job.draco_for_older || !p.caps.any_mesh_codec;
    job.key_halves_for_older = job.key_halves_for_older || !p.caps.key_half_steps;
    job.coordinates_for_older = job.coordinates_for_older || !p.caps.edge_places;
    if (!p.wants_layers) continue;
    (p.wants_layer_video ? wanted.video : wanted.lz4) = true;
    wanted.lz4_camera_planes = wanted.lz4_camera_planes || !p.caps.zstd_planes;
    wanted.own_normal_charts = wanted.own_normal_charts || !p.caps.surface_facing_charts;
    if (p.wants_layer_video && !p.layer_video_in_step) worker_->requestLayerVideoKeyFrame();
  }
  worker_->setLayersWanted(wanted);
  job.group = std::move(group);
  job.late_frames = sync_.lateFrames();
  job.dropped_groups = sync_.overflowedGroups() + worker_->replacedJobs();
  for (const auto& [pod, jitter] : pod_arrivals_) {
    protocol::PodArrivals arrivals{
        static_cast<uint16_t>(pod), jitter.packets(),
        static_cast<uint32_t>(std::min(jitter.ms() * 1000.0 + 0.5, 4.0e9))};
    for (const Peer& p : peers) {
      if (!p.greeted || p.replaced || p.role != protocol::Role::kPod || p.id != pod ||
          !p.clock.known())
        continue;
      arrivals.clock_offset_ns = p.clock.offsetNs();
      arrivals.clock_uncertainty_ns = std::max<uint64_t>(p.clock.uncertaintyNs(), 1);
    }
    job.pod_arrivals.push_back(arrivals);
  }
  worker_->submit(std::move(job));
}

void FramePipeline::fanOut(std::vector<Peer>& peers) {
  for (auto& out : worker_->takeOutputs()) {
    ++groups_fused_;
    if (recorder_)
      recorder_->recordFused(out.frame_id, *out.mesh_frame, *out.texture_bundle, *out.stats);
    for (auto& peer : peers) {
      if (!peer.isClient()) continue;
      // A client before 1.7 decodes Draco meshes only, and one before 1.11
      // Draco's keys as halves only: none was made for a frame fused
      // before it joined, and it gets none of that frame.
      const protocol::SharedFrame& mesh = peer.caps.key_half_steps   ? out.mesh_frame
                                          : peer.caps.any_mesh_codec ? out.mesh_frame_v1_10
                                                                     : out.mesh_frame_draco;
      if (!mesh) continue;
      // A client that asked for none more does not get this frame (another
      // client asked); its layers' video, if any, is out of step from here.
      if (peer.caps.asks_for_frames && peer.framesOwed() == 0) {
        peer.layer_video_in_step = false;
        continue;
      }
      // Bundle and Stats first: the client renders when the mesh arrives.
      // A client that asked for layers gets the images of a frame whose
      // layers were refused (the Stats' note says why).
      protocol::SharedFrame bundle = out.bundleFor(peer.caps.bundle);
      if (peer.wants_layer_video) {
        // Its stream is in step from a key frame on, until a frame of it
        // does not reach the client (refused layers, a drop on a slow link).
        // Out of step, a predicted frame is one it cannot decode: it gets
        // nothing until the key frame it asked for.
        // A client before 1.11 joined after this frame was taken: its
        // spelling was not made, and it waits for a later key frame.
        if (out.texture_bundle_layer_video) {
          const protocol::SharedFrame& layers = peer.caps.zstd_planes
                                                    ? out.texture_bundle_layer_video
                                                    : out.texture_bundle_layer_video_v1_10;
          if (out.layer_stats.video_key_frame && layers) peer.layer_video_in_step = true;
          if (!peer.layer_video_in_step || !layers) {
            peer.layer_video_in_step = false;
            worker_->requestLayerVideoKeyFrame();
            continue;
          }
          bundle = layers;
        } else {
          peer.layer_video_in_step = false;
        }
      } else if (peer.wants_layers) {
        const protocol::SharedFrame& layers =
            peer.caps.zstd_planes ? out.texture_bundle_layers : out.texture_bundle_layers_v1_10;
        if (layers) bundle = layers;
      }
      // A frame a client asked for is never dropped from its queue: it
      // asks for the next only as this one arrives, and its request bounds
      // the queue.
      using Keep = protocol::Connection::Keep;
      const Keep keep = peer.caps.asks_for_frames ? Keep::kAlways : Keep::kAsFlagged;
      ++peer.frames_sent;
      peer.connection->send(bundle, keep);
      peer.connection->send(out.statsFor(peer.caps.stats));
      peer.connection->send(mesh, keep);
      if (peer.connection->framesDropped() != peer.frames_dropped_seen) {
        peer.frames_dropped_seen = peer.connection->framesDropped();
        peer.layer_video_in_step = false;
      }
      if (peer.wants_layer_video && !peer.layer_video_in_step) worker_->requestLayerVideoKeyFrame();
    }
  }
}

bool FramePipeline::readable(const Peer& peer, const std::vector<Peer>& peers) {
  if (!peer.greeted || peer.role != protocol::Role::kPod) return true;
  if (!clients_arrived_) {
    int clients = 0;
    for (const auto& other : peers) clients += other.isClient();
    if (clients < options_.wait_for_clients) return false;
    clients_arrived_ = true;  // from now on pods are read whoever comes and goes
  }
  // Backpressure on a pod whose frames are still being decoded: they
  // wait in its socket, and its bounded queue drops the oldest.
  if (decoder_->inFlight(peer.id) >= options_.max_frames_in_flight) return false;
  if (!options_.lossless) return true;
  // Frames wait in the pod's socket, and the pod's sends block, until
  // fusion has caught up: nothing is dropped and memory stays bounded.
  // A group for every fusion thread and one waiting.
  const size_t max_queued_groups = static_cast<size_t>(worker_->threads()) + 1;
  constexpr size_t kMaxPendingPerPod = 4;
  return worker_->queuedJobs() < max_queued_groups &&
         sync_.pendingWith(peer.id) < kMaxPendingPerPod;
}

bool FramePipeline::podsDone(const std::vector<Peer>& peers) const {
  // Every configured pod joined and left (not just the first ones).
  if (departed_pods_.size() < static_cast<size_t>(options_.pods)) return false;
  if (decoder_->inFlight() > 0 || sync_.pendingGroups() > 0 || worker_->queuedJobs() > 0 ||
      held_group_)
    return false;
  for (const auto& peer : peers) {
    if (!peer.greeted) continue;
    if (peer.role == protocol::Role::kPod || peer.connection->wantsWrite()) return false;
  }
  return true;
}

}  // namespace holofuse::fusion
