// ./holofuse bench loop (bench/bench_loop.cpp) on a short run: the live
// loop started for real per mode and run, medians over the runs in
// bench_loop.json and the table, an earlier run's numbers set beside
// them, and a baseline that is not one refused by name.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "process_harness.h"

namespace holofuse::test {
namespace {

const std::string kBin = HOLOFUSE_BIN_DIR;

TEST(BenchLoop, RunsTheLoopPerModeAndSetsABaselineBesideIt) {
  const fs::path out = freshDir("bench_loop");
  // An earlier run, as bench_loop writes it, with numbers no run here gives.
  fs::create_directories(out / "before");
  std::ofstream(out / "before" / "bench_loop.json") << R"({"modes": {"normal": {
      "fps": 1.5, "end_to_end": {"p50": 901.5, "p95": 952.5},
      "stages": {"hull": {"p50": 77.7, "p95": 88.8}}}}})";
  const pid_t bench =
      spawn({kBin + "/bench_loop", "--modes", "normal,layered", "--frames", "4", "--repeats", "2",
             "--out", (out / "now").string(), "--baseline", (out / "before").string(), "--",
             "--fps", kSanitized ? "1" : "4", "--size", "160x120"},
            out / "bench.log");
  ASSERT_EQ(waitExit(bench, 600), 0) << readFile(out / "bench.log");
  std::ifstream in(out / "now" / "bench_loop.json");
  const auto json = nlohmann::json::parse(in);
  for (const std::string mode : {"normal", "layered"}) {
    const auto& m = json["modes"][mode];
    EXPECT_EQ(m["runs"].size(), 2u) << mode;
    EXPECT_GT(m["fps"].get<double>(), 0.0) << mode;
    EXPECT_GE(m["end_to_end"]["p95"].get<double>(), m["end_to_end"]["p50"].get<double>());
    for (const std::string stage : {"pod_render", "hull", "render", "write"}) {
      ASSERT_TRUE(m["stages"].contains(stage)) << mode << " " << stage << ": " << m.dump();
      EXPECT_GT(m["stages"][stage]["p50"].get<double>(), 0.0) << mode << " " << stage;
    }
  }
  EXPECT_TRUE(json["modes"]["layered"]["stages"].contains("layers")) << "the server's layer stage";
  EXPECT_FALSE(json["modes"]["normal"]["stages"].contains("layers")) << "stages with no samples";
  // Each run's own report is kept beside the summary.
  EXPECT_TRUE(fs::exists(out / "now" / "runs" / "layered-2" / "report.json"));
  const std::string md = readFile(out / "now" / "bench_loop.md");
  EXPECT_NE(md.find("| normal | 1.5 -> "), std::string::npos) << md;
  EXPECT_NE(md.find("| hull | 77.7 -> "), std::string::npos) << md;
  EXPECT_NE(md.find("- normal: "), std::string::npos) << "the targets' verdicts: " << md;
  EXPECT_NE(readFile(out / "now" / "bench_loop.html").find("<svg"), std::string::npos);

  const pid_t refused = spawn({kBin + "/bench_loop", "--modes", "normal", "--frames", "4", "--out",
                               (out / "again").string(), "--baseline", (out / "nothing").string()},
                              out / "refused.log");
  EXPECT_EQ(waitExit(refused, 60), 2);
  EXPECT_NE(readFile(out / "refused.log").find("no bench_loop.json there"), std::string::npos)
      << readFile(out / "refused.log");
  EXPECT_FALSE(fs::exists(out / "again" / "runs")) << "refused before any run";
  fs::remove_all(out);
}

}  // namespace
}  // namespace holofuse::test
