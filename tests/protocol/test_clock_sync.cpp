// ClockSync against exchanges whose true offset and one-way delays are
// chosen: the estimate must land within its stated uncertainty of the truth,
// pick the quickest exchange, refuse impossible answers, and tell a drifting
// clock from a noisy one.
#include <gtest/gtest.h>

#include <cstdlib>

#include "protocol/clock_sync.h"

namespace holofuse::protocol {
namespace {

constexpr uint64_t kMs = 1000000;

// One exchange through a peer whose clock reads ours + offset: the request
// takes `out` ns on the way, the peer answers after `hold`, the reply takes
// `back`. Returns our clock when the reply arrives.
uint64_t exchange(ClockSync& sync, uint64_t now, int64_t offset, uint64_t out, uint64_t hold,
                  uint64_t back, Status* status = nullptr) {
  auto probe = sync.probeDue(now);
  EXPECT_TRUE(probe.has_value()) << "no probe due at " << now;
  if (!probe) return now;
  const uint64_t arrived = now + out;
  const ClockProbe reply = ClockSync::answer(*probe, arrived + offset, arrived + hold + offset);
  const uint64_t back_home = arrived + hold + back;
  const Status s = sync.onReply(reply, back_home);
  if (status != nullptr) *status = s;
  EXPECT_TRUE(status != nullptr || s.isOk()) << s.toString();
  return back_home;
}

TEST(ClockSync, FindsAPeerSecondsAheadWithinItsUncertaintyOnAsymmetricPaths) {
  ClockSync sync;
  EXPECT_FALSE(sync.known());
  const int64_t truth = 5'000'000'000;  // the peer's clock is 5 s ahead of ours
  uint64_t now = 1000 * kMs;
  // Asymmetric and varying ways: 0.3 ms out and 2.1 ms back, and so on.
  const uint64_t outs[] = {300000, 900000, 150000, 2000000};
  const uint64_t backs[] = {2100000, 400000, 180000, 2500000};
  for (int k = 0; k < 4; ++k) now = exchange(sync, now, truth, outs[k], 50000, backs[k]) + 1;
  ASSERT_TRUE(sync.known());
  // The third exchange had the smallest round trip: 0.33 ms.
  EXPECT_EQ(sync.roundTripNs(), 330000u);
  EXPECT_LE(std::llabs(sync.offsetNs() - truth), static_cast<long long>(sync.uncertaintyNs()));
  EXPECT_EQ(sync.uncertaintyNs(), 165000u);
  // A time on the peer's clock comes back onto ours, and the reverse.
  EXPECT_NEAR(static_cast<double>(sync.toLocal(9'000'000'000)), 4'000'000'000.0, 165000.0);
  EXPECT_NEAR(static_cast<double>(sync.toPeer(1'000'000'000)), 6'000'000'000.0, 165000.0);
  EXPECT_EQ(sync.describe(), "+4999.985 ms +- 0.165 ms");
}

TEST(ClockSync, BurstsAfterTheHandshakeThenProbesOncePerInterval) {
  ClockSyncOptions options;
  options.interval_ms = 1000;
  options.burst = 3;
  ClockSync sync(options);
  uint64_t now = 10 * kMs;
  for (int k = 0; k < 3; ++k) {
    const auto probe = sync.probeDue(now);
    ASSERT_TRUE(probe.has_value()) << "burst probe " << k;
    EXPECT_FALSE(sync.probeDue(now + 1).has_value()) << "one in flight at a time";
    ASSERT_TRUE(
        sync.onReply(ClockSync::answer(*probe, now + kMs / 2, now + kMs / 2), now + kMs).isOk());
    now += kMs;
  }
  const uint64_t last = now - kMs;  // the burst's last probe went then
  EXPECT_FALSE(sync.probeDue(last + 999 * kMs).has_value()) << "burst over: wait the interval";
  EXPECT_TRUE(sync.probeDue(last + 1000 * kMs).has_value());
  // An unanswered probe is given up after the reply timeout (2 s).
  EXPECT_FALSE(sync.probeDue(last + 2999 * kMs).has_value());
  EXPECT_TRUE(sync.probeDue(last + 3000 * kMs).has_value());
}

TEST(ClockSync, RefusesAnswersThatAreNotOursOrImpossible) {
  ClockSync sync;
  const auto probe = sync.probeDue(100 * kMs);
  ASSERT_TRUE(probe.has_value());
  // Answers no probe in flight.
  ClockProbe stranger = ClockSync::answer(ClockProbe{ProbeStep::kRequest, 7, 0, 0}, 8, 9);
  Status s = sync.onReply(stranger, 101 * kMs);
  EXPECT_EQ(s.code(), StatusCode::kUnexpectedMessage);
  EXPECT_NE(s.message().find("origin 7"), std::string::npos) << s.message();
  // Answered before it was received.
  ClockProbe backwards = ClockSync::answer(*probe, 500 * kMs, 400 * kMs);
  s = sync.onReply(backwards, 101 * kMs);
  EXPECT_EQ(s.code(), StatusCode::kMalformed);
  EXPECT_NE(s.message().find("impossible"), std::string::npos) << s.message();
  EXPECT_FALSE(sync.known()) << "a refused answer changes nothing";
  // Held longer than the whole round trip.
  const auto again = sync.probeDue(200 * kMs);
  ASSERT_TRUE(again.has_value());
  s = sync.onReply(ClockSync::answer(*again, 0, 50 * kMs), 201 * kMs);
  EXPECT_EQ(s.code(), StatusCode::kMalformed);
  EXPECT_FALSE(sync.known());
  // A request is not a reply.
  const auto third = sync.probeDue(300 * kMs);
  ASSERT_TRUE(third.has_value());
  EXPECT_FALSE(sync.onReply(*third, 301 * kMs).isOk());
  // An offset past 2^62 ns is nonsense, refused before any arithmetic on it.
  const auto fourth = sync.probeDue(2400 * kMs);  // the third timed out
  ASSERT_TRUE(fourth.has_value());
  s = sync.onReply(ClockSync::answer(*fourth, uint64_t{1} << 63, (uint64_t{1} << 63) + 10),
                   2401 * kMs);
  EXPECT_EQ(s.code(), StatusCode::kMalformed);
  EXPECT_NE(s.message().find("s from ours"), std::string::npos) << s.message();
  EXPECT_FALSE(sync.known());
}

TEST(ClockSync, WarnsOfDriftOnlyBeyondTheEstimatesUncertainty) {
  ClockSyncOptions options;
  options.interval_ms = 1000;
  options.burst = 4;
  options.window = 4;
  ClockSync sync(options);
  uint64_t now = 1000 * kMs;
  for (int k = 0; k < 4; ++k) now = exchange(sync, now, 0, 200000, 10000, 200000) + 1;
  EXPECT_EQ(sync.driftNs(), 0);
  // Noise within the uncertainty: a sample with a slow way back moves
  // nothing (the filter keeps the quicker ones).
  now = exchange(sync, now + 1000 * kMs, 0, 200000, 10000, 4000000);
  EXPECT_FALSE(sync.drifted(1 * kMs));
  // The peer's clock runs away: 3 ms ahead after a few more samples.
  for (int k = 0; k < 4; ++k)
    now = exchange(sync, now + 1000 * kMs, 3 * kMs, 200000, 10000, 200000);
  EXPECT_NEAR(static_cast<double>(sync.driftNs()), 3.0 * kMs, 200000.0);
  EXPECT_TRUE(sync.drifted(1 * kMs));
  EXPECT_FALSE(sync.drifted(5 * kMs)) << "a 5 ms threshold is not passed by 3 ms";
}

TEST(ClockSync, ShiftsStampsOntoOurClockAndKeepsOpenEndsOpen) {
  std::vector<StageStamp> stamps = {{1, 2, 5'000'000'100, 5'000'000'200}, {10, 0xFFFF, 7000, 0}};
  shiftStamps(stamps, 5'000'000'000);
  EXPECT_EQ(stamps[0].start_ns, 100u);
  EXPECT_EQ(stamps[0].end_ns, 200u);
  EXPECT_EQ(stamps[1].end_ns, 0u) << "an open stamp stays open";
  EXPECT_EQ(shiftedNs(100, -3'000'000'000), 3'000'000'100u);
  // A time the offset would take below zero stays a valid, earliest time.
  EXPECT_EQ(shiftedNs(100, 1'000'000'000), 1u);
}

}  // namespace
}  // namespace holofuse::protocol
