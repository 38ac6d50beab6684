// Frame sync deadlines, and whole fusions of a group.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "codec/image_codec.h"
#include "codec/mesh_codec.h"
#include "fusion_server/frame_sync.h"
#include "fusion_server/fusion_worker.h"
#include "fusion_server/pod_decoder.h"
#include "hull/hull_error.h"
#include "hull/synthetic_views.h"
#include "hull/visual_hull.h"
#include "hull/vulkan_hull_grid.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::fusion {
namespace {

using test::syntheticViews;

PodImages imagesOf(uint32_t camera_id) {
  PodImages images;
  images.camera_id = camera_id;
  return images;
}

TEST(FrameSync, CompleteGroupsGoAtOnceLateOnesAtTheDeadline) {
  FrameSync sync(100);
  const std::set<uint32_t> expected = {0, 1, 2};
  for (uint32_t cam : {0u, 1u, 2u}) sync.add(5, imagesOf(cam), 10);
  auto ready = sync.takeReady(expected, 11);
  ASSERT_EQ(ready.size(), 1u);
  EXPECT_TRUE(ready[0].complete);
  // Frame 6 misses camera 2: nothing before the deadline, then it goes.
  sync.add(6, imagesOf(0), 20);
  sync.add(6, imagesOf(1), 21);
  EXPECT_TRUE(sync.takeReady(expected, 50).empty());
  ready = sync.takeReady(expected, 120);
  ASSERT_EQ(ready.size(), 1u);
  EXPECT_FALSE(ready[0].complete);
  EXPECT_EQ(ready[0].pods.size(), 2u);
  // Camera 2's frame 6 arrives after its group went: counted late.
  EXPECT_EQ(sync.add(6, imagesOf(2), 130), FrameSync::Added::kLate);
  EXPECT_EQ(sync.lateFrames(), 1u);
}

// Lossless (replays at full speed): no deadline, but a pod that skipped an
// id (it sent a later one) does not stall the group that lacks it.
TEST(FrameSync, LosslessGroupsWaitForTheirPodsButNotForSkippedIds) {
  FrameSync sync = FrameSync::lossless();
  const std::set<uint32_t> expected = {0, 1};
  for (uint64_t id : {1, 2, 4}) sync.add(id, imagesOf(0), 0);
  for (uint64_t id : {1, 2, 3}) sync.add(id, imagesOf(1), 0);
  // Hours later nothing has expired by time: 1 and 2 are complete; 3 lacks
  // pod 0, which has sent 4 since, so it goes too; 4 waits for pod 1.
  auto ready = sync.takeReady(expected, uint64_t{1} << 60);
  ASSERT_EQ(ready.size(), 3u);
  EXPECT_TRUE(ready[0].complete && ready[1].complete);
  EXPECT_EQ(ready[2].frame_id, 3u);
  EXPECT_FALSE(ready[2].complete);
  EXPECT_EQ(ready[2].pods.count(1), 1u);
  EXPECT_EQ(sync.pendingWith(0), 1u);
  EXPECT_TRUE(sync.takeReady(expected, uint64_t{1} << 61).empty());
  EXPECT_FALSE(sync.nextDeadline().has_value());
  sync.add(4, imagesOf(1), 0);
  ready = sync.takeReady(expected, 0);
  ASSERT_EQ(ready.size(), 1u);
  EXPECT_TRUE(ready[0].complete);
  EXPECT_EQ(sync.overflowedGroups(), 0u);
}

// The first id seen is bogus (far in the future) and goes out alone: a
// single pod is the rig's clock. Once most pods say otherwise the sync
// starts over on their clock, and the bogus pod is off it.
TEST(FrameSync, ABogusFirstFrameIdCannotMakeEveryoneLate) {
  FrameSync sync(10);
  const uint64_t bogus = uint64_t{1} << 62;
  EXPECT_EQ(sync.add(bogus, imagesOf(0), 0), FrameSync::Added::kAccepted);
  ASSERT_EQ(sync.takeReady({0, 1, 2}, 100).size(), 1u);
  // Two pods that disagree: the clock being fused wins.
  EXPECT_EQ(sync.add(500, imagesOf(1), 101), FrameSync::Added::kOffClock);
  // A third: the median is theirs, and the sync starts over on it.
  EXPECT_EQ(sync.add(500, imagesOf(2), 102), FrameSync::Added::kAccepted);
  EXPECT_EQ(sync.clockResets(), 1u);
  EXPECT_EQ(sync.add(501, imagesOf(1), 103), FrameSync::Added::kAccepted);
  EXPECT_EQ(sync.add(bogus + 1, imagesOf(0), 104), FrameSync::Added::kOffClock);
  ASSERT_NE(sync.clockOf(0), nullptr);
  EXPECT_GT(sync.clockOf(0)->offset, int64_t{1} << 61);
  EXPECT_EQ(sync.clockOf(0)->voters, 3u);
  // Pod 0 is off the clock: group 501 does not wait for it.
  EXPECT_EQ(sync.add(501, imagesOf(2), 105), FrameSync::Added::kAccepted);
  const auto ready = sync.takeReady({0, 1, 2}, 106);
  ASSERT_EQ(ready.size(), 1u);
  EXPECT_EQ(ready[0].frame_id, 501u);
  EXPECT_TRUE(ready[0].complete) << "without pod 0";
}

// A pod on another clock, ahead or behind by a little or a lot, loses its
// own frames only: three pods on the rig's ids keep being fused whole and
// none of them is late, and the groups never wait for the off pod. Once it
// leaves, the next pod 3 is judged afresh.
TEST(FrameSync, OnePodsClockNeverDecidesTheOthers) {
  for (const int64_t skew : {int64_t{9}, int64_t{-9}, int64_t{54000}, int64_t{-54000},
                             int64_t{90000}, int64_t{-90000}, int64_t{1} << 50}) {
    FrameSync sync(10);
    const std::set<uint32_t> all = {0, 1, 2, 3};
    uint64_t now = 0;
    for (uint64_t id = 1000000; id < 1000010; ++id) {
      for (uint32_t pod = 0; pod < 3; ++pod)
        EXPECT_EQ(sync.add(id, imagesOf(pod), ++now), FrameSync::Added::kAccepted) << skew;
      EXPECT_EQ(sync.add(id + static_cast<uint64_t>(skew), imagesOf(3), ++now),
                FrameSync::Added::kOffClock)
          << skew;
      const auto ready = sync.takeReady(all, ++now);
      ASSERT_EQ(ready.size(), 1u) << skew;
      EXPECT_EQ(ready[0].frame_id, id);
      EXPECT_EQ(ready[0].pods.size(), 3u);
      EXPECT_TRUE(ready[0].complete) << "not waiting for the pod off the clock";
    }
    ASSERT_NE(sync.clockOf(3), nullptr);
    EXPECT_EQ(sync.clockOf(3)->offset, skew);
    EXPECT_EQ(sync.clockOf(3)->off_frames, 10u);
    EXPECT_EQ(sync.clockOf(3)->off_since_ns, 4u) << "since its first frame";
    EXPECT_EQ(sync.clockResets(), 0u);
    EXPECT_EQ(sync.lateFrames(), 0u);
    // It leaves; a pod 3 on the rig's clock is fused with the others.
    sync.forgetPod(3);
    EXPECT_EQ(sync.clockOf(3), nullptr);
    for (uint32_t pod = 0; pod < 4; ++pod)
      EXPECT_EQ(sync.add(1000010, imagesOf(pod), ++now), FrameSync::Added::kAccepted);
    const auto ready = sync.takeReady(all, ++now);
    ASSERT_EQ(ready.size(), 1u);
    EXPECT_TRUE(ready[0].complete);
    EXPECT_EQ(ready[0].pods.size(), 4u);
  }
}

// A pod a few ids ahead, within the bound: its frames wait in their groups
// past the deadline, and the others fill them when the rig's clock gets
// there, so every group goes out whole.
TEST(FrameSync, APodALittleAheadWaitsForTheOthers) {
  FrameSync sync(10);
  const std::set<uint32_t> all = {0, 1, 2};
  uint64_t now = 0;
  // Pod 2 runs 3 ids ahead; the deadline is 10 and a frame period 20.
  for (uint64_t id = 100; id < 112; ++id) {
    EXPECT_EQ(sync.add(id, imagesOf(0), now), FrameSync::Added::kAccepted);
    EXPECT_EQ(sync.add(id, imagesOf(1), now), FrameSync::Added::kAccepted);
    EXPECT_EQ(sync.add(id + 3, imagesOf(2), now), FrameSync::Added::kAccepted);
    const auto ready = sync.takeReady(all, now);
    if (id >= 103) {  // pod 2 sent no ids below 103
      ASSERT_EQ(ready.size(), 1u) << id;
      EXPECT_EQ(ready[0].frame_id, id);
      EXPECT_TRUE(ready[0].complete);
      EXPECT_EQ(sync.nextDeadline(), std::nullopt) << "groups ahead of the clock do not expire";
    }
    now += 20;  // past any deadline: only the groups the clock reached go
    for (const FrameGroup& group : sync.takeReady(all, now))
      EXPECT_LT(group.frame_id, 103u) << "pod 2's frame went out alone";
  }
  EXPECT_EQ(sync.lateFrames(), 0u);
  EXPECT_EQ(sync.overflowedGroups(), 0u);
}

// A pod that went quiet stops voting after the window (a second here), so
// two stalled pods cannot hold the clock back for the two that go on.
TEST(FrameSync, APodThatWentQuietStopsVoting) {
  FrameSync sync(10);
  uint64_t now = 0;
  for (uint32_t pod = 0; pod < 4; ++pod) sync.add(100, imagesOf(pod), ++now);
  now += 2'000'000'000ull;
  // Pods 2 and 3 stalled; 0 and 1 come back 40 ids on (two seconds later).
  EXPECT_EQ(sync.add(140, imagesOf(0), ++now), FrameSync::Added::kAccepted);
  EXPECT_EQ(sync.add(140, imagesOf(1), ++now), FrameSync::Added::kAccepted);
  EXPECT_EQ(sync.clockOf(1)->voters, 2u);
}

TEST(FrameSync, ADeadPodDoesNotStallWhenItIsNoLongerExpected) {
  FrameSync sync(1000000);
  sync.add(9, imagesOf(0), 0);
  EXPECT_TRUE(sync.takeReady({0, 1}, 1).empty());
  EXPECT_EQ(sync.takeReady({0}, 2).size(), 1u);  // pod 1 disconnected
}

// Pod 1 ran ahead of pod 0 and both left: its frames past the rig's
// clock (the clock stopped with the pods) still go at the deadline, so a
// server that stops when its pods are done is not kept waiting forever.
TEST(FrameSync, FramesAheadOfTheClockGoOnceTheirPodsHaveLeft) {
  FrameSync sync(10);
  sync.add(0, imagesOf(0), 0);
  for (uint64_t id = 0; id < 3; ++id) sync.add(id, imagesOf(1), 1);
  EXPECT_EQ(sync.takeReady({0, 1}, 2).size(), 1u);  // frame 0, whole
  EXPECT_TRUE(sync.takeReady({0, 1}, 100).empty()) << "pod 0 may still send 1 and 2";
  sync.forgetPod(1);
  EXPECT_TRUE(sync.takeReady({0}, 100).empty()) << "pod 0 may still send 1 and 2";
  sync.forgetPod(0);
  const auto ready = sync.takeReady({}, 100);
  ASSERT_EQ(ready.size(), 2u);
  EXPECT_EQ(ready[0].frame_id, 1u);
  EXPECT_EQ(ready[1].frame_id, 2u);
  EXPECT_FALSE(ready[1].complete);
  EXPECT_EQ(sync.pendingGroups(), 0u);
}

// The send stage is the server's: it runs from the pod's encode end to the
// arrival, and a send stamp the pod put in its own frame is not kept (it
// would count twice for the pod's jitter, with times the pod chose).
// Frames come out of the decoder in the order they went in, however many
// threads decode them: a pod's ids must reach the sync as they grew.
TEST(PodDecoder, FramesComeOutInTheOrderTheyWentInOnAnyThread) {
  const int wake = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  ASSERT_GE(wake, 0);
  constexpr int kFrames = 64;
  std::vector<DecodedPodFrame> out;
  {
    PodDecoder decoder(4, wake);
    for (int i = 0; i < kFrames; ++i) {
      protocol::PodFrame pod;
      pod.camera_id = static_cast<uint32_t>(i % 3);
      pod.frame_id = static_cast<uint64_t>(i);
      protocol::StreamDecoder stream;
      stream.feed(protocol::encodeOutgoing(pod, static_cast<uint64_t>(i)).flatten());
      ASSERT_TRUE(stream.hasFrame());
      // Pod 0's frames are its own; the others claim another id and are
      // refused, so results are quick and slow in turn.
      decoder.submit({static_cast<uint64_t>(i), 0, stream.takeFrame(), Camera{}, 0});
    }
    EXPECT_EQ(decoder.inFlight(), static_cast<size_t>(kFrames));
    while (out.size() < kFrames) {
      pollfd p{wake, POLLIN, 0};
      ASSERT_GT(::poll(&p, 1, 10000), 0) << "the decoder went quiet after " << out.size();
      uint64_t counter = 0;
      while (::read(wake, &counter, sizeof(counter)) > 0) {
      }
      for (auto& decoded : decoder.takeDecoded()) out.push_back(std::move(decoded));
    }
    EXPECT_EQ(decoder.inFlight(), 0u);
    EXPECT_TRUE(decoder.podsInFlight().empty());
  }
  ::close(wake);
  for (int i = 0; i < kFrames; ++i) {
    EXPECT_EQ(out[i].connection, static_cast<uint64_t>(i));
    EXPECT_FALSE(out[i].status.isOk());
    if (i % 3 != 0) {
      EXPECT_NE(out[i].status.message().find("pod_frame.camera_id"), std::string::npos)
          << out[i].status.message();
    }
  }
}

TEST(FusionWorker, TheServerStampsTheSendStageItself) {
  const auto views = syntheticViews(1, 3, 64, 48);
  const scene::SyntheticScene scene;
  const Image8 color = scene.render(views[0].camera, 3).color;
  protocol::PodFrame pod;
  pod.frame_id = 3;
  pod.capture_time_ns = 1000;
  pod.stamps = {
      {static_cast<uint16_t>(protocol::Stage::kPodEncode), 0, 1500, 2000},
      {static_cast<uint16_t>(protocol::Stage::kSend), 0, 1, 999'999}};  // not the pod's to say
  std::vector<uint8_t> storage[3];
  pod.planes = {
      encodePlane(color, protocol::PlaneKind::kColor, protocol::Codec::kLz4, storage[0]),
      encodePlane(views[0].mask, protocol::PlaneKind::kMask, protocol::Codec::kLz4, storage[1]),
      encodePlane(views[0].feather, protocol::PlaneKind::kFeather, protocol::Codec::kLz4,
                  storage[2])};
  auto images = podImagesOf(pod, 4096, views[0].camera, 5000);
  ASSERT_TRUE(images.isOk()) << images.status().toString();
  EXPECT_EQ(images->sent_ns, 2000u) << "the pod's encode end";
  EXPECT_EQ(images->arrival_ns, 5000u);
  const auto sends = std::count_if(
      images->stamps.begin(), images->stamps.end(), [](const protocol::StageStamp& s) {
        return s.stage == static_cast<uint16_t>(protocol::Stage::kSend);
      });
  EXPECT_EQ(sends, 1);
  // A pod whose clock reads 900 ns ahead of the server's: its times come
  // onto the server's clock, the jitter keeps the pod's own send time.
  auto shifted = podImagesOf(pod, 4096, views[0].camera, 5000, 900);
  ASSERT_TRUE(shifted.isOk());
  EXPECT_EQ(shifted->capture_time_ns, 100u);
  EXPECT_EQ(shifted->sent_ns, 1100u);
  EXPECT_EQ(shifted->pod_sent_ns, 2000u);
  EXPECT_EQ(shifted->stamps.front().start_ns, 600u);
  // An estimate of -3100 ns places the pod's send (2000) at 5100, 100 ns
  // after its arrival. Within an uncertainty of 150 ns that is a transit
  // of 0; beyond one of 50 ns it stays negative, and the report leaves it
  // out.
  for (const uint64_t uncertainty : {150u, 50u}) {
    auto early = podImagesOf(pod, 4096, views[0].camera, 5000, -3100, uncertainty);
    ASSERT_TRUE(early.isOk());
    EXPECT_EQ(early->sent_ns, 5100u);
    const auto send =
        std::find_if(early->stamps.begin(), early->stamps.end(), [](const protocol::StageStamp& s) {
          return s.stage == static_cast<uint16_t>(protocol::Stage::kSend);
        });
    ASSERT_NE(send, early->stamps.end());
    EXPECT_EQ(send->end_ns, 5000u);
    EXPECT_EQ(send->start_ns, uncertainty == 150u ? 5000u : 5100u) << uncertainty;
  }
  // Not measured yet: none of the pod's stamps, and its capture time is the
  // arrival, the latest it can have been.
  auto unplaced = podImagesOf(pod, 4096, views[0].camera, 5000, std::nullopt);
  ASSERT_TRUE(unplaced.isOk());
  EXPECT_EQ(unplaced->capture_time_ns, 5000u);
  EXPECT_EQ(unplaced->pod_sent_ns, 2000u);
  for (const auto& s : unplaced->stamps)
    EXPECT_EQ(s.stage, static_cast<uint16_t>(protocol::Stage::kServerDecode)) << s.stage;
}

TEST(FusionWorker, FusesAGroupIntoDecodableFrames) {
  const auto views = syntheticViews(4, 3, 160, 120);
  GroupJob job;
  job.group.frame_id = 3;
  job.group.complete = false;
  const scene::SyntheticScene scene;
  for (size_t i = 0; i < 3; ++i) {  // camera 3 is missing
    PodImages pod;
    pod.camera_id = static_cast<uint32_t>(i);
    pod.color = scene.render(views[i].camera, 3).color;
    pod.mask = views[i].mask;
    pod.feather = views[i].feather;
    pod.camera = views[i].camera;
    pod.bytes = 1000;
    job.group.pods[pod.camera_id] = pod;
  }
  FusionSettings settings;
  settings.pods_expected = 4;
  const FusedOutput out = fuseGroup(job, settings);
  auto decode = [](const protocol::SharedFrame& frame) {
    protocol::StreamDecoder d;
    d.feed(frame->flatten());
    EXPECT_TRUE(d.hasFrame());
    return d.takeFrame();
  };
  protocol::MeshFrame mesh;
  const protocol::Frame mesh_bytes = decode(out.mesh_frame);  // the decoded spans point into it
  ASSERT_TRUE(protocol::decodeFrame(mesh_bytes, mesh).isOk());
  auto decoded = decodeDraco(mesh.mesh.data(), mesh.mesh.size());
  ASSERT_TRUE(decoded.isOk());
  EXPECT_EQ(decoded->triangleCount(), mesh.triangle_count);
  EXPECT_GT(mesh.triangle_count, 500u);
  protocol::Stats stats;
  ASSERT_TRUE(protocol::decodeFrame(decode(out.stats), stats).isOk());
  EXPECT_EQ(stats.cameras_present, 0x7u);
  EXPECT_EQ(stats.pod_bytes, 3000u);
  EXPECT_NE(stats.note.find("3"), std::string::npos) << stats.note;
  protocol::TextureBundle bundle;
  ASSERT_TRUE(protocol::decodeFrame(decode(out.texture_bundle), bundle).isOk());
  EXPECT_EQ(bundle.images.size(), 3u);
}

// Every output of a lossless worker fed jobs, in the order it gave them.
std::vector<FusedOutput> fuseAll(const FusionSettings& settings,
                                 const std::vector<GroupJob>& jobs) {
  const int wake = ::eventfd(0, EFD_NONBLOCK);
  EXPECT_GE(wake, 0);
  std::vector<FusedOutput> outputs;
  {
    FusionWorker worker(settings, wake, /*lossless=*/true);
    for (const GroupJob& job : jobs) worker.submit(job);
    // The worker writes the descriptor as each fused group is ready.
    while (outputs.size() < jobs.size()) {
      pollfd woken{wake, POLLIN, 0};
      if (::poll(&woken, 1, 120'000) <= 0) break;  // a limit for a hung worker, not a pace
      uint64_t counter = 0;
      if (::read(wake, &counter, sizeof(counter)) < 0) break;
      for (auto& out : worker.takeOutputs()) outputs.push_back(std::move(out));
    }
  }
  ::close(wake);
  return outputs;
}

// A frame's payload as the client decodes it: the mesh bytes, or every
// image plane's bytes (not the header: its sequence number and stamps
// differ from run to run). The decoded spans point into the frame, so
// take reads them before it goes.
template <typename Message, typename Take>
std::vector<uint8_t> payloadOf(const protocol::SharedFrame& frame, Take take) {
  protocol::StreamDecoder decoder;
  decoder.feed(frame->flatten());
  EXPECT_TRUE(decoder.hasFrame());
  const protocol::Frame bytes = decoder.takeFrame();
  Message message;
  EXPECT_TRUE(protocol::decodeFrame(bytes, message).isOk());
  return take(message);
}

std::vector<uint8_t> meshBytes(const protocol::SharedFrame& frame) {
  return payloadOf<protocol::MeshFrame>(frame, [](const protocol::MeshFrame& mesh) {
    return std::vector<uint8_t>(mesh.mesh.begin(), mesh.mesh.end());
  });
}

std::vector<uint8_t> imageBytes(const protocol::SharedFrame& frame) {
  return payloadOf<protocol::TextureBundle>(frame, [](const protocol::TextureBundle& bundle) {
    std::vector<uint8_t> all;
    for (const auto& image : bundle.images) {
      for (const auto& plane : image.planes)
        all.insert(all.end(), plane.data.begin(), plane.data.end());
    }
    return all;
  });
}

// One group of four synthetic pods at 160x120, frame frame_id.
GroupJob syntheticJob(uint64_t frame_id) {
  const scene::SyntheticScene scene;
  const auto views = syntheticViews(4, frame_id, 160, 120);
  GroupJob job;
  job.group.frame_id = frame_id;
  for (size_t i = 0; i < views.size(); ++i) {
    PodImages pod;
    pod.camera_id = static_cast<uint32_t>(i);
    pod.color = scene.render(views[i].camera, frame_id).color;
    pod.mask = views[i].mask;
    pod.feather = views[i].feather;
    pod.camera = views[i].camera;
    job.group.pods[pod.camera_id] = pod;
  }
  return job;
}

// A hull goes to clients of 1.13 as its keys and places along their
// edges: every vertex on its key's edge, in fewer bytes. While a client
// before 1.13 is connected every client gets the coordinates, the same
// vertices within their quantisation.
TEST(FusionWorker, AHullGoesAsPlacesAlongItsKeysEdgesUnlessAnOlderClientIsHere) {
  const GroupJob job = syntheticJob(3);
  FusionSettings settings;
  settings.pods_expected = 4;
  auto meshOf = [&](bool older_client) {
    GroupJob taken = job;
    taken.coordinates_for_older = older_client;
    const FusedOutput out = fuseGroup(taken, settings);
    std::vector<uint8_t> bytes = meshBytes(out.mesh_frame);
    auto mesh = decodeDraco(bytes.data(), bytes.size());
    EXPECT_TRUE(mesh.isOk()) << mesh.status().toString();
    return std::make_pair(bytes.size(), mesh.isOk() ? *mesh : Mesh{});
  };
  const auto [place_bytes, on_edges] = meshOf(false);
  const auto [coordinate_bytes, coordinates] = meshOf(true);
  ASSERT_GT(on_edges.vertexCount(), 100u);
  EXPECT_LT(place_bytes * 4, coordinate_bytes * 3)
      << place_bytes << " against " << coordinate_bytes << " bytes";
  const glm::u64vec3 lattice = hull::keyLattice(settings.hull);
  const double s = settings.hull.voxel_size;
  // How far a vertex is off its key's edge, the largest coordinate.
  auto offEdge = [&](uint64_t key, const glm::vec3& p) {
    const uint64_t axis = key % 3, point = key / 3;
    const uint64_t at[3] = {point % lattice.x, point / lattice.x % lattice.y,
                            point / (lattice.x * lattice.y)};
    double off = 0;
    for (uint64_t k = 0; k < 3; ++k) {
      const double d = double(p[k]) - (settings.hull.volume_min[k] + s * double(at[k]));
      off = std::max(off, k == axis ? std::max(-d, d - s) : std::abs(d));
    }
    return off;
  };
  std::map<uint64_t, glm::vec3> by_key;
  double worst_coordinate = 0;
  for (size_t v = 0; v < coordinates.vertexCount(); ++v) {
    by_key[coordinates.vertex_keys[v]] = coordinates.positions[v];
    worst_coordinate =
        std::max(worst_coordinate, offEdge(coordinates.vertex_keys[v], coordinates.positions[v]));
  }
  EXPECT_GT(worst_coordinate, 1e-5) << "coordinates are quantised off the lattice";
  ASSERT_EQ(by_key.size(), on_edges.vertexCount());
  for (size_t v = 0; v < on_edges.vertexCount(); ++v) {
    const uint64_t key = on_edges.vertex_keys[v];
    EXPECT_LE(offEdge(key, on_edges.positions[v]), 1e-5) << "vertex " << v;
    ASSERT_EQ(by_key.count(key), 1u) << key;
    EXPECT_LT(glm::length(by_key[key] - on_edges.positions[v]), 2e-3f) << "vertex " << v;
  }
}

// The settings syntheticJobs() fuse with: four pods, 30 mm voxels.
FusionSettings syntheticSettings(int threads) {
  FusionSettings settings;
  settings.pods_expected = 4;
  settings.hull.voxel_size = 0.03;
  settings.threads = threads;
  return settings;
}

// Six groups of four synthetic pods at 160x120.
std::vector<GroupJob> syntheticJobs() {
  std::vector<GroupJob> jobs;
  for (uint64_t frame = 0; frame < 6; ++frame) jobs.push_back(syntheticJob(10 + 3 * frame));
  return jobs;
}

// Groups fused several at once, each hull spread over threads, come out
// in the order they went in, byte for byte what one thread makes.
TEST(FusionWorker, AnyThreadCountFusesTheSameBytesInTheSameOrder) {
  const std::vector<GroupJob> jobs = syntheticJobs();
  FusionSettings settings = syntheticSettings(1);
  const std::vector<FusedOutput> one = fuseAll(settings, jobs);
  ASSERT_EQ(one.size(), jobs.size());
  for (const int threads : {2, 3}) {
    settings.threads = threads;
    const std::vector<FusedOutput> many = fuseAll(settings, jobs);
    ASSERT_EQ(many.size(), jobs.size()) << threads << " threads";
    for (size_t k = 0; k < jobs.size(); ++k) {
      EXPECT_EQ(many[k].frame_id, jobs[k].group.frame_id) << threads << " threads, output " << k;
      EXPECT_EQ(many[k].triangles, one[k].triangles) << threads << " threads, output " << k;
      EXPECT_GT(many[k].triangles, 100u) << "a subject was carved";
      EXPECT_TRUE(meshBytes(many[k].mesh_frame) == meshBytes(one[k].mesh_frame))
          << threads << " threads, frame " << many[k].frame_id << ": other mesh bytes";
      EXPECT_TRUE(imageBytes(many[k].texture_bundle) == imageBytes(one[k].texture_bundle))
          << threads << " threads, frame " << many[k].frame_id << ": other image bytes";
    }
  }
  // The frames differ from one another: equal bytes are not one frame's.
  EXPECT_FALSE(meshBytes(one[0].mesh_frame) == meshBytes(one[5].mesh_frame));
}

// A server that replays stops once every pod has left and its worker has
// nothing queued, so a group still being finished (its images packed, in
// turn) must count as queued until its output is in: otherwise the last
// frame of a replay is lost now and then (seen in CI).
TEST(FusionWorker, AGroupBeingFinishedCountsAsQueuedUntilItsOutputIsIn) {
  const std::vector<GroupJob> jobs = syntheticJobs();
  const FusionSettings settings = syntheticSettings(3);
  const int wake = ::eventfd(0, EFD_NONBLOCK);
  ASSERT_GE(wake, 0);
  size_t outputs = 0;
  {
    FusionWorker worker(settings, wake, /*lossless=*/true);
    for (const GroupJob& job : jobs) worker.submit(job);
    // Asked without pause, as the server's loop asks between events: the
    // first moment nothing is queued, every output must be there.
    while (worker.queuedJobs() > 0) outputs += worker.takeOutputs().size();
    outputs += worker.takeOutputs().size();
  }
  ::close(wake);
  EXPECT_EQ(outputs, jobs.size());
}

// The hull carved on the device (--hull-device vulkan, lavapipe here),
// one group at a time or three: the same bytes in the same order, and
// about the CPU's triangles (the same surface to float rounding), also
// where the device's buffers had to grow.
TEST(FusionWorker, OnTheDeviceAnyThreadCountFusesTheSameBytes) {
  const std::vector<GroupJob> jobs = syntheticJobs();
  FusionSettings settings;
  settings.pods_expected = 4;
  // 10 mm: the first frames' corners outgrow the device's first buffer,
  // so one is marched again, whichever thread's group comes first.
  settings.hull.voxel_size = 0.01;
  settings.threads = 1;
  const std::vector<FusedOutput> cpu = fuseAll(settings, jobs);
  const auto device = hull::VulkanHullGrid::open();
  settings.hull.surface = hull::deviceSurface(device);
  const std::vector<FusedOutput> one = fuseAll(settings, jobs);
  EXPECT_GE(device->remarches(), 1u);
  const auto fresh = hull::VulkanHullGrid::open();  // overflowing again, now on three threads
  settings.hull.surface = hull::deviceSurface(fresh);
  settings.threads = 3;
  const std::vector<FusedOutput> many = fuseAll(settings, jobs);
  EXPECT_GE(fresh->remarches(), 1u);
  ASSERT_EQ(one.size(), jobs.size());
  ASSERT_EQ(many.size(), jobs.size());
  for (size_t k = 0; k < jobs.size(); ++k) {
    EXPECT_EQ(many[k].frame_id, jobs[k].group.frame_id) << "output " << k;
    EXPECT_TRUE(meshBytes(many[k].mesh_frame) == meshBytes(one[k].mesh_frame))
        << "frame " << many[k].frame_id << ": other mesh bytes on 3 threads";
    EXPECT_NEAR(static_cast<double>(one[k].triangles), static_cast<double>(cpu[k].triangles),
                0.002 * static_cast<double>(cpu[k].triangles) + 2)
        << "frame " << one[k].frame_id;
  }
}

// Under an error target the worker carves each group once, at a voxel that
// follows the measured silhouette error: finer after each miss.
TEST(FusionWorker, AnErrorTargetRefinesTheVoxelUntilTheSilhouettesAgree) {
  GroupJob job = syntheticJob(3);
  FusionSettings settings;
  settings.pods_expected = 4;
  settings.hull.voxel_size = 0.05;
  settings.hull_error_target = 0.0025;
  // One group at a time: each is taken after the one before was measured
  // (with several in flight the voxel follows the groups finished).
  settings.threads = 1;
  std::vector<GroupJob> jobs;
  for (int frame = 0; frame < 6; ++frame) {
    job.group.frame_id = 3 + static_cast<uint64_t>(frame);
    jobs.push_back(job);
  }
  const std::vector<FusedOutput> outputs = fuseAll(settings, jobs);
  ASSERT_EQ(outputs.size(), 6u);
  EXPECT_DOUBLE_EQ(outputs[0].voxel_size, 0.05);
  ASSERT_TRUE(outputs[0].silhouette_error.valid);
  EXPECT_GT(outputs[0].silhouette_error.mean_m, settings.hull_error_target) << "the start misses";
  bool met = false;
  for (size_t k = 1; k < outputs.size(); ++k) {
    ASSERT_TRUE(outputs[k].silhouette_error.valid);
    const bool missed = outputs[k - 1].silhouette_error.mean_m > settings.hull_error_target;
    if (missed) {
      EXPECT_NEAR(outputs[k].voxel_size, outputs[k - 1].voxel_size * hull::kVoxelStep, 1e-12) << k;
    } else {
      EXPECT_LE(outputs[k].voxel_size, 0.05) << "never coarser than the start";
    }
    // The same group again: once met, it stays met (no swinging back).
    if (met) {
      EXPECT_LE(outputs[k].silhouette_error.mean_m, settings.hull_error_target) << k;
    }
    met = met || outputs[k].silhouette_error.mean_m <= settings.hull_error_target;
  }
  EXPECT_TRUE(met) << "met within six frames";
}

}  // namespace
}  // namespace holofuse::fusion

namespace holofuse::fusion {
namespace {

TEST(MeshCodecKeys, VertexKeysSurviveDracoExactly) {
  const Mesh hull = hull::carveVisualHull(syntheticViews(4, 3, 120, 90), hull::HullOptions{});
  auto bytes = encodeDraco(hull);
  ASSERT_TRUE(bytes.isOk());
  auto back = decodeDraco(bytes->data(), bytes->size());
  ASSERT_TRUE(back.isOk());
  ASSERT_EQ(back->vertex_keys.size(), back->vertexCount());
  // Draco reorders vertices: compare as sets, and each key's position.
  std::map<uint64_t, glm::vec3> original;
  for (size_t v = 0; v < hull.vertexCount(); ++v) original[hull.vertex_keys[v]] = hull.positions[v];
  for (size_t v = 0; v < back->vertexCount(); ++v) {
    auto it = original.find(back->vertex_keys[v]);
    ASSERT_NE(it, original.end());
    EXPECT_LT(glm::length(it->second - back->positions[v]), 2e-3f);  // 11-bit quantisation
  }
}

}  // namespace
}  // namespace holofuse::fusion
