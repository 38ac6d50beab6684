// The latency report's arithmetic: percentiles, end to end settled by the
// final clock estimate, and each frame's timeline and shares by stage.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>

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

}  // namespace
}  // namespace holofuse::report
