// The latency report's arithmetic: percentiles, end to end settled by the
// final clock estimate, and each frame's timeline and shares by stage.
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <random>

#include "base/statistics.h"
#include "protocol/clock_sync.h"
#include "report/latency_report.h"

namespace holofuse::report {
namespace {

TEST(LatencyReport, PercentilesInterpolate) {
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4, 5}, 50), 3);
  EXPECT_DOUBLE_EQ(percentile({10, 20}, 50), 15);
  EXPECT_DOUBLE_EQ(percentile({}, 95), 0);
  EXPECT_DOUBLE_EQ(percentile({7}, 99), 7);
}

// A frame written while the client's only clock sample came from a reply
// read late (the client was rendering) is placed again by the final,
// better estimate: its end to end is neither negative nor wrapped round.
TEST(LatencyReport, EndToEndIsSettledByTheFinalClockEstimate) {
  protocol::ClockSync clock(protocol::ClockSyncOptions{1, 1, 8, 2000});
  // The server's clock equals ours. A probe at 1.000 s answered at once,
  // its reply read 140 ms later: offset estimate -70 ms (+- 70 ms).
  auto probe = clock.probeDue(1'000'000'000);
  ASSERT_TRUE(probe.has_value());
  ASSERT_TRUE(
      clock
          .onReply(protocol::ClockSync::answer(*probe, 1'000'000'000, 1'000'000'000), 1'140'000'000)
          .isOk());
  LatencyReport report;
  FrameRecord frame;
  frame.capture_time_ns = 1'150'000'000;   // server's clock
  frame.written_local_ns = 1'170'000'000;  // 20 ms later, on ours
  const uint64_t written = clock.toPeer(frame.written_local_ns);
  frame.end_to_end_ms =
      static_cast<double>(static_cast<int64_t>(written - frame.capture_time_ns)) / 1e6;
  EXPECT_NEAR(frame.end_to_end_ms, -50.0, 1e-6) << "placed by the late reply's estimate";
  report.addFrame(frame, written);
  // A reply read at once: the estimate becomes the truth, 0.
  probe = clock.probeDue(2'000'000'000);
  ASSERT_TRUE(probe.has_value());
  ASSERT_TRUE(
      clock
          .onReply(protocol::ClockSync::answer(*probe, 2'000'000'000, 2'000'000'000), 2'000'000'000)
          .isOk());
  report.settleEndToEnd(clock);
  EXPECT_NEAR(report.frames().front().end_to_end_ms, 20.0, 1e-6);
  EXPECT_NEAR(report.endToEndPercentile(95), 20.0, 1e-6);
}

// Each frame's timeline keeps one span a stage, the pod the group waited
// for where several pods stamped it, in pipeline order and in ms from the
// capture; the gap between two spans is a wait the stages do not name.
TEST(LatencyReport, EachFrameSaysWhereItsTimeWent) {
  using protocol::Stage;
  const auto stamp = [](Stage stage, uint16_t source, uint64_t start_ms, uint64_t end_ms) {
    return protocol::StageStamp{static_cast<uint16_t>(stage), source,
                                1'000'000'000 + start_ms * 1'000'000,
                                1'000'000'000 + end_ms * 1'000'000};
  };
  FrameRecord frame;
  frame.capture_time_ns = 1'000'000'000;
  frame.timeline = timelineOf({
      stamp(Stage::kRender, protocol::kSourceClient, 60, 100),
      stamp(Stage::kSend, 1, 5, 8),
      stamp(Stage::kSend, 0, 4, 12),  // the pod the group waited for
      stamp(Stage::kHull, protocol::kSourceServer, 30, 45),
      stamp(Stage::kSyncWait, protocol::kSourceServer, 8, 12),
      {static_cast<uint16_t>(Stage::kFanout), protocol::kSourceServer, 2'000'000'000, 0},
  });
  ASSERT_EQ(frame.timeline.size(), 4u) << "the fanout never ended";
  LatencyReport report;
  report.addFrame(frame, 1'100'000'000);
  const auto json = nlohmann::ordered_json::parse(report.toJson({}));  // in its written order
  const auto& timeline = json["frames"][0]["timeline_ms"];
  std::vector<std::string> names;
  for (const auto& [stage, span] : timeline.items()) names.push_back(stage);
  EXPECT_EQ(names, (std::vector<std::string>{"send", "sync_wait", "hull", "render"}));
  EXPECT_DOUBLE_EQ(timeline["send"][0].get<double>(), 4.0);
  EXPECT_DOUBLE_EQ(timeline["send"][1].get<double>(), 12.0);
  // 18 ms between the group's sync and its hull: held, or queued.
  EXPECT_DOUBLE_EQ(timeline["hull"][0].get<double>() - timeline["sync_wait"][1].get<double>(),
                   18.0);
  EXPECT_DOUBLE_EQ(timeline["render"][1].get<double>(), 100.0);
  // Its 100 ms: send 4-12 (the sync wait's 8-12 goes to the send, earlier
  // in the pipeline), hull 15, render 40, and 37 when no stage ran.
  frame.end_to_end_ms = 100;
  const std::vector<double> shares = timeByStage(frame);
  const auto& order = protocol::stagesInPipelineOrder();
  const auto share = [&](Stage stage) {
    return shares[std::find(order.begin(), order.end(), static_cast<uint16_t>(stage)) -
                  order.begin()];
  };
  EXPECT_DOUBLE_EQ(share(Stage::kSend), 8.0);
  EXPECT_DOUBLE_EQ(share(Stage::kSyncWait), 0.0);
  EXPECT_DOUBLE_EQ(share(Stage::kHull), 15.0);
  EXPECT_DOUBLE_EQ(share(Stage::kRender), 40.0);
  EXPECT_DOUBLE_EQ(shares.back(), 37.0);
}

// A client rendering for days (a soak's, a viewer left open) keeps its
// report in bounded memory: the soak found one growing 1.6 KB a frame,
// every frame and every stage's sample kept. 50 000 frames more than a
// warm-up add nothing to the heap in use, and the figures still describe
// the whole run: counts, sums, means and worst exactly, percentiles from
// an even spread of it, the last frames listed in full.
TEST(LatencyReport, ALongRunHoldsBoundedMemoryAndDescribesTheWholeRun) {
  using protocol::Stage;
  constexpr uint64_t kFrameNs = 33'000'000;
  const auto frameAt = [&](uint64_t k) {
    const uint64_t capture = 1'000'000'000 + k * kFrameNs;
    FrameRecord frame;
    frame.frame_id = k;
    frame.file = "frames/frame_" + std::to_string(k) + ".png";
    frame.capture_time_ns = capture;
    frame.end_to_end_ms = 50.0 + static_cast<double>(k % 100);
    frame.cameras_present = k % 10 == 0 ? 3 : 4;
    frame.cameras_expected = 4;
    frame.pod_bytes = 1000 + k % 3;
    frame.client_bytes = 500;
    frame.mesh_triangles = 2000 + k % 50;
    frame.quality = FrameQuality{30.0 + 0.1 * static_cast<double>(k % 10), 0.9};
    std::vector<protocol::StageStamp> stamps;
    for (uint16_t pod = 0; pod < 4; ++pod)
      stamps.push_back({static_cast<uint16_t>(Stage::kSend), pod, capture + 5'000'000,
                        capture + 6'000'000 + (k % 7) * 100'000});
    stamps.push_back({static_cast<uint16_t>(Stage::kServerDecode), protocol::kSourceServer,
                      capture + 7'000'000, capture + 9'000'000});
    stamps.push_back({static_cast<uint16_t>(Stage::kHull), protocol::kSourceServer,
                      capture + 9'000'000, capture + 20'000'000});
    frame.timeline = timelineOf(stamps);
    return std::pair{frame, stamps};
  };
  LatencyReport report;
  const auto add = [&](uint64_t k) {
    auto [frame, stamps] = frameAt(k);
    report.addStamps(stamps);
    report.addStage(static_cast<uint16_t>(Stage::kRender), 10.0 + static_cast<double>(k % 20));
    report.addGpuPass("seams", 1.0);
    report.addJudgeMs(2.0);
    report.addFrame(frame, frame.capture_time_ns + 60'000'000);
  };
  constexpr uint64_t kWarmUp = 5000, kFrames = 55000;
  for (uint64_t k = 0; k < kWarmUp; ++k) add(k);
  const size_t heap_warm = mallinfo2().uordblks;
  for (uint64_t k = kWarmUp; k < kFrames; ++k) add(k);
  const size_t heap_after = mallinfo2().uordblks;
  EXPECT_LT(heap_after, heap_warm + 64 * 1024)
      << "the heap in use grew by " << (heap_after - heap_warm) << " bytes over "
      << kFrames - kWarmUp << " frames";

  EXPECT_EQ(report.framesRendered(), kFrames);
  EXPECT_NEAR(report.fps(), 1e9 / static_cast<double>(kFrameNs), 1e-6);
  // End to end runs evenly over 50..149 ms: the even spread finds its p50.
  EXPECT_NEAR(report.endToEndPercentile(50), 99.5, 2.0);
  EXPECT_NEAR(report.endToEndPercentile(95), 144.5, 2.0);
  const auto json = nlohmann::json::parse(report.toJson({}));
  EXPECT_EQ(json["frames_rendered"], kFrames);
  EXPECT_EQ(json["frames_listed"], LatencyReport::kFramesListed);
  ASSERT_EQ(json["frames"].size(), LatencyReport::kFramesListed);
  EXPECT_EQ(json["frames"].back()["frame_id"], kFrames - 1) << "the last frames are listed";
  EXPECT_EQ(json["frames_with_missing_cameras"], kFrames / 10);
  EXPECT_NEAR(json["bytes_per_frame"]["pod_link"].get<double>(), 1001.0, 1e-3);
  EXPECT_EQ(json["mesh_triangles"]["max"], 2049);
  EXPECT_EQ(json["latency_ms"]["stages"]["render"]["samples"], kFrames);
  EXPECT_NEAR(json["latency_ms"]["stages"]["render"]["p50"].get<double>(), 19.5, 1.0);
  EXPECT_EQ(json["latency_ms"]["gpu_passes"]["seams"]["samples"], kFrames);
  EXPECT_EQ(json["latency_ms"]["links"]["pod_3_to_server"]["samples"], kFrames);
  EXPECT_EQ(json["server_pipeline"]["frame_pairs"], kFrames - 1);
  EXPECT_EQ(json["server_pipeline"]["overlapped"], 0) << "each frame fused after the one before";
  const auto quality = report.quality();
  ASSERT_EQ(quality.size(), 2u);
  EXPECT_EQ(quality[0].frames, kFrames);
  EXPECT_NEAR(quality[0].mean, 30.45, 1e-9);
  EXPECT_DOUBLE_EQ(quality[0].worst, 30.0);
  // The slowest frames are kept apart, the slowest first.
  const std::vector<FrameRecord> slowest = report.slowestFrames();
  ASSERT_EQ(slowest.size(), LatencyReport::kSlowestKept);
  for (const FrameRecord& frame : slowest) EXPECT_DOUBLE_EQ(frame.end_to_end_ms, 149.0);
}

// The pods' jitter, when the server sends none, is RFC 3550's over the
// frames in order of arrival, though the client learns of them out of
// order and keeps only the latest few waiting to be sorted.
TEST(LatencyReport, JitterIsTakenInOrderOfArrivalFromStampsLearntOutOfOrder) {
  std::mt19937 random(7);
  std::vector<std::pair<double, double>> pairs;  // sent, received (ms)
  for (int k = 0; k < 3000; ++k) {
    const double sent = 33.0 * k;
    pairs.emplace_back(sent, sent + 4.0 + std::uniform_real_distribution<double>(0, 3)(random));
  }
  std::vector<std::pair<double, double>> learnt = pairs;
  for (size_t at = 0; at + 16 <= learnt.size(); at += 16)  // shuffled within 16 frames
    std::shuffle(learnt.begin() + static_cast<std::ptrdiff_t>(at),
                 learnt.begin() + static_cast<std::ptrdiff_t>(at + 16), random);
  LatencyReport report;
  for (const auto& [sent, received] : learnt) {
    report.addStamps({{static_cast<uint16_t>(protocol::Stage::kSend), 2,
                       static_cast<uint64_t>(sent * 1e6), static_cast<uint64_t>(received * 1e6)}});
  }
  ASSERT_EQ(report.podJitterMs().count(2), 1u);
  EXPECT_NEAR(report.podJitterMs().at(2), interarrivalJitter(pairs), 1e-6);
  EXPECT_GT(report.podJitterMs().at(2), 0.1);
}

// Reasons for frames skipped: the first are named, every one is counted.
TEST(LatencyReport, SkippedFramesAreCountedAndTheFirstNamed) {
  LatencyReport report;
  for (int k = 0; k < 250; ++k) report.noteSkipped("frame " + std::to_string(k) + ": no mesh");
  EXPECT_EQ(report.skippedCount(), 250u);
  const std::vector<std::string> listed = report.skippedFrames();
  ASSERT_EQ(listed.size(), LatencyReport::kReasonsListed + 1);
  EXPECT_EQ(listed.front(), "frame 0: no mesh");
  EXPECT_EQ(listed.back(), "and 150 more frames");
}

}  // namespace
}  // namespace holofuse::report
