// The soak's judge on samples made here (flat, growing, a process gone,
// too short), and a short soak of the real loop: every process sampled,
// the report written for people and programs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "deploy/soak.h"
#include "integration/process_harness.h"

namespace holofuse::deploy {
namespace {

namespace fs = std::filesystem;

SoakSample sampleAt(double minute, std::vector<std::optional<ProcessUsage>> usage) {
  return SoakSample{minute, std::move(usage)};
}

ProcessUsage usage(uint64_t rss_mb, int descriptors = 10, int threads = 4) {
  return ProcessUsage{rss_mb * 1024, rss_mb * 1024, descriptors, threads};
}

TEST(Soak, FlatWithinFivePercentAfterTheWarmUpAndNotOtherwise) {
  // The warm-up may grow as it likes; after it, 100 to 104 MB is flat.
  std::vector<SoakSample> samples = {sampleAt(1, {usage(40)}), sampleAt(2, {usage(100)}),
                                     sampleAt(3, {usage(104)}), sampleAt(4, {usage(101)})};
  const SoakVerdict flat = judgeSoak({"server"}, samples, 2);
  EXPECT_TRUE(flat.flat) << ::testing::PrintToString(flat.problems);
  ASSERT_EQ(flat.trends.size(), 3u);
  EXPECT_EQ(flat.trends[0].quantity, "rss_mb");
  EXPECT_DOUBLE_EQ(flat.trends[0].min, 100);
  EXPECT_DOUBLE_EQ(flat.trends[0].max, 104);
  // 100 to 106 MB is a leak of 6%; one more descriptor in 10 is 10%.
  samples.push_back(sampleAt(5, {usage(106, 11)}));
  const SoakVerdict growing = judgeSoak({"server"}, samples, 2);
  EXPECT_FALSE(growing.flat);
  ASSERT_EQ(growing.problems.size(), 2u);
  EXPECT_NE(growing.problems[0].find("server rss_mb moved from 100.0 to 106.0"), std::string::npos)
      << growing.problems[0];
  EXPECT_NE(growing.problems[1].find("server descriptors moved from 10.0 to 11.0"),
            std::string::npos)
      << growing.problems[1];
}

// A picture being written when a sample is taken holds one descriptor
// more: back to the least by the last sample, that is no leak. Memory that
// comes back down is still judged by its spread.
TEST(Soak, ADescriptorHeldAtOneSampleAndGivenBackIsNoLeak) {
  const std::vector<SoakSample> transient = {
      sampleAt(3, {usage(100, 6)}), sampleAt(4, {usage(100, 7)}), sampleAt(5, {usage(100, 6)})};
  EXPECT_TRUE(judgeSoak({"client"}, transient, 2).flat);
  std::vector<SoakSample> leaking = transient;
  leaking.push_back(sampleAt(6, {usage(100, 7)}));
  EXPECT_FALSE(judgeSoak({"client"}, leaking, 2).flat) << "still held at the end";
  const std::vector<SoakSample> memory = {sampleAt(3, {usage(100)}), sampleAt(4, {usage(120)}),
                                          sampleAt(5, {usage(100)})};
  EXPECT_FALSE(judgeSoak({"client"}, memory, 2).flat);
}

TEST(Soak, AProcessGoneOrASoakTooShortIsNotFlat) {
  const std::vector<SoakSample> gone = {sampleAt(3, {usage(100), usage(20)}),
                                        sampleAt(4, {usage(100), std::nullopt}),
                                        sampleAt(5, {usage(100), std::nullopt})};
  const SoakVerdict verdict = judgeSoak({"server", "pod 0"}, gone, 2);
  EXPECT_FALSE(verdict.flat);
  ASSERT_FALSE(verdict.problems.empty());
  EXPECT_EQ(verdict.problems[0], "pod 0 was gone at minute 4.0");
  const SoakVerdict short_one = judgeSoak({"server"}, {sampleAt(1, {usage(5)})}, 2);
  EXPECT_FALSE(short_one.flat);
  EXPECT_NE(short_one.problems.at(0).find("too short to tell: 0 sample(s) after the 2.0-minute"),
            std::string::npos)
      << short_one.problems.at(0);
}

// The real loop soaked for 24 s, sampled every 4 s: a row per sample with
// every process alive, and the verdict consistent with the trends it lists.
TEST(Soak, TheLoopSoaksWithEveryProcessSampled) {
  const fs::path out = test::freshDir("soak");
  const pid_t soak =
      test::spawn({std::string(HOLOFUSE_BIN_DIR) + "/holofuse_loop", "--pods", "2", "--clients",
                   "2", "--size", "64x48", "--soak-minutes", "0.4", "--sample-seconds", "4",
                   "--warmup-minutes", "0.1", "--out", out.string()},
                  out.string() + ".log");
  const int code = test::waitExit(soak, 180);
  ASSERT_TRUE(code == 0 || code == 1) << test::readFile(out.string() + ".log");
  std::ifstream in(out / "soak.json");
  const auto report = nlohmann::json::parse(in);
  const std::vector<std::string> processes = {"server", "pod 0", "pod 1", "client 0", "client 1"};
  EXPECT_EQ(report["processes"].get<std::vector<std::string>>(), processes);
  ASSERT_GE(report["samples"].size(), 5u);
  for (const auto& sample : report["samples"]) {
    for (const std::string& p : processes) {
      ASSERT_TRUE(sample["usage"][p].is_object()) << p << " gone at " << sample["minute"];
      EXPECT_GT(sample["usage"][p]["rss_kb"].get<uint64_t>(), 1000u) << p;
      EXPECT_GT(sample["usage"][p]["descriptors"].get<int>(), 2) << p;
      EXPECT_GE(sample["usage"][p]["threads"].get<int>(), 1) << p;
    }
  }
  bool all_trends_flat = true;
  for (const auto& trend : report["trends"]) all_trends_flat &= trend["flat"].get<bool>();
  EXPECT_EQ(report["flat"].get<bool>(), all_trends_flat);
  EXPECT_EQ(code == 0, report["flat"].get<bool>()) << "the exit code says the verdict";
  for (const char* file : {"soak.md", "soak.html", "client0/report.json", "client1/report.json"})
    EXPECT_TRUE(fs::exists(out / file)) << file;
  fs::remove_all(out);
}

}  // namespace
}  // namespace holofuse::deploy
