// The sweep: bad knobs refused before any work, points written whole and
// resumed after an interruption (only under the settings they were
// measured with), the Pareto front and the default's place.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <thread>

#include "browser_check.h"
#include "config/command_line.h"
#include "eval/sweep.h"
#include "integration/process_harness.h"
#include "small_dataset.h"
#include "sweep_points.h"

namespace holofuse::eval {
namespace {

namespace fs = std::filesystem;

std::string readText(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

SweepOptions tinySweep(const std::string& dir) {
  SweepOptions options;
  options.base.scenes = {"few-cameras"};
  options.base.frames = 1;
  options.base.width = 96;
  options.base.height = 72;
  options.base.held_out_cameras = 1;
  options.base.modes = {render::BlendMode::kNormal};
  options.out_dir = dir;
  return options;
}

TEST(Sweep, ParetoFrontKeepsWhatNothingBeatsBeyondNoise) {
  auto point = [](double psnr, double ms, double ms_p95) {
    return TradePoint{psnr, {timeCost(ms, ms_p95)}};
  };
  const std::vector<TradePoint> points = {
      point(10.0, 5.0, 5.0),     // 0: beaten by 1 on both
      point(11.0, 4.0, 4.0),     // 1
      point(12.0, 9.0, 9.0),     // 2: better quality at more cost
      point(12.0, 9.5, 9.5),     // 3: 2's time within 10%: a tie, not beaten
      point(12.0, 20.0, 20.0),   // 4: as good as 2, clearly slower: beaten
      point(12.005, 11.0, 14.0)  // 5: slower than 2, but within its own spread: a tie
  };
  EXPECT_EQ(paretoFront(points), (std::vector<size_t>{1, 2, 3, 5}));
  EXPECT_TRUE(dominates(points[2], points[4]));
  EXPECT_FALSE(dominates(points[2], points[3]));
  EXPECT_FALSE(dominates(points[3], points[2]));
  // PSNR within 0.01 dB is a tie, beyond it a gain; bytes within 0.5% tie.
  const TradePoint base{19.5, {timeCost(30, 31), bytesCost(1e6)}};
  EXPECT_FALSE(dominates(TradePoint{19.505, {timeCost(30, 31), bytesCost(1e6)}}, base));
  EXPECT_TRUE(dominates(TradePoint{19.52, {timeCost(30, 31), bytesCost(1e6)}}, base));
  EXPECT_FALSE(dominates(TradePoint{19.5, {timeCost(30, 31), bytesCost(0.997e6)}}, base));
  EXPECT_TRUE(dominates(TradePoint{19.5, {timeCost(30, 31), bytesCost(0.99e6)}}, base));
  EXPECT_FALSE(dominates(TradePoint{19.6, {timeCost(30, 31), bytesCost(1.01e6)}}, base))
      << "more bytes";
  EXPECT_FALSE(dominates(TradePoint{19.6, {timeCost(30.5, 31), bytesCost(1e6)}}, base))
      << "slower, if within noise";
  // SSIM is judged beside PSNR where both points have it.
  const TradePoint sharp{19.5, {timeCost(30, 31), bytesCost(1e6)}, 0.69};
  EXPECT_TRUE(dominates(TradePoint{19.5, {timeCost(30, 31), bytesCost(1e6)}, 0.70}, sharp));
  EXPECT_FALSE(dominates(TradePoint{19.5, {timeCost(30, 31), bytesCost(1e6)}, 0.6905}, sharp))
      << "SSIM within its tie";
  EXPECT_FALSE(dominates(TradePoint{19.6, {timeCost(30, 31), bytesCost(0.9e6)}, 0.68}, sharp))
      << "a better PSNR and fewer bytes for a blurrier picture";
  EXPECT_TRUE(dominates(TradePoint{19.6, {timeCost(30, 31), bytesCost(0.9e6)}}, sharp))
      << "without SSIM on both, PSNR and costs decide";
  // Three points each cheapest in one cost, the others within 15%: none
  // beats another, so all stay (a rule that forgave small losses would
  // let each beat the next around a circle and leave no front).
  const std::vector<TradePoint> circle = {
      {19.5, {timeCost(100, 100), timeCost(107, 107), timeCost(115, 115)}},
      {19.5, {timeCost(115, 115), timeCost(100, 100), timeCost(107, 107)}},
      {19.5, {timeCost(107, 107), timeCost(115, 115), timeCost(100, 100)}}};
  EXPECT_EQ(paretoFront(circle), (std::vector<size_t>{0, 1, 2}));
  EXPECT_EQ(paretoFront({point(1.0, 1.0, 1.0), point(1.0, 1.0, 1.0)}), (std::vector<size_t>{0, 1}))
      << "equal points both stay";
}

TEST(Sweep, BadKnobsAndValuesAreRefusedBeforeAnyWork) {
  const fs::path dir = fs::temp_directory_path() / "holofuse_sweep_bad";
  fs::remove_all(dir);
  SweepOptions options = tinySweep(dir.string());
  options.knobs = {{"alpha", {"1", "2"}}, {"brightness", {"3"}}};
  {
    const auto refused = runSweep(options);
    ASSERT_FALSE(refused.isOk()) << "unknown knob accepted";
    const std::string what = refused.isOk() ? "" : refused.status().message();
    EXPECT_NE(what.find("brightness"), std::string::npos);
    EXPECT_NE(what.find("draco-bits"), std::string::npos) << "lists the knobs";
  }
  options.knobs = {{"alpha", {"1"}}, {"size", {"320x"}}};
  {
    const auto refused = runSweep(options);
    ASSERT_FALSE(refused.isOk()) << "bad value accepted";
    const std::string what = refused.isOk() ? "" : refused.status().message();
    EXPECT_NE(what.find("size: '320x'"), std::string::npos);
  }
  options.knobs = {{"alpha", {"1", "4"}}, {"K", {"20"}}, {"alpha", {"5"}}};
  {
    const auto refused = runSweep(options);
    ASSERT_FALSE(refused.isOk()) << "a knob given twice accepted";
    const std::string what = refused.isOk() ? "" : refused.status().message();
    EXPECT_NE(what.find("knob 'alpha' is given twice"), std::string::npos) << what;
  }
  EXPECT_FALSE(fs::exists(dir / "points")) << "nothing ran, nothing written";
}

TEST(Sweep, AnInterruptedSweepKeepsFinishedPointsAndResumes) {
  const fs::path dir = fs::temp_directory_path() / "holofuse_sweep_resume";
  fs::remove_all(dir);
  SweepOptions options = tinySweep(dir.string());
  options.knobs = {{"alpha", {"1", "2", "8"}}, {"K", {"12"}}};
  const auto first = runSweep(options).value();
  ASSERT_EQ(first.size(), 5u) << "K swept without its default gets it";
  for (size_t i = 0; i < 4; ++i) EXPECT_FALSE(first[i].resumed);
  EXPECT_TRUE(first[1].is_default) << "alpha 2 is the default";
  EXPECT_FALSE(first[3].is_default);
  EXPECT_EQ(first[4].knob + "=" + first[4].value, "K=20");
  EXPECT_TRUE(first[4].is_default && first[4].resumed)
      << "K = 20 is the same run as alpha = 2: not run twice";
  EXPECT_DOUBLE_EQ(first[4].result.modes.at("normal").psnr_db,
                   first[1].result.modes.at("normal").psnr_db);
  options.knobs.pop_back();
  // As if killed while the last point ran: its file never appeared, a
  // partial one did.
  fs::remove(dir / "points" / "alpha=8.json");
  std::ofstream(dir / "points" / "alpha=8.json.partial") << "{\"knob\": \"alp";
  const auto second = runSweep(options).value();
  ASSERT_EQ(second.size(), 3u);
  EXPECT_TRUE(second[0].resumed);
  EXPECT_TRUE(second[1].resumed);
  EXPECT_FALSE(second[2].resumed);
  EXPECT_DOUBLE_EQ(second[0].result.modes.at("normal").psnr_db,
                   first[0].result.modes.at("normal").psnr_db);
  EXPECT_DOUBLE_EQ(second[0].result.bytes_per_frame, first[0].result.bytes_per_frame);
  ASSERT_TRUE(writeSweepReports(options, second).isOk());
  std::ifstream in(dir / "sweep.json");
  const auto json = nlohmann::json::parse(in);
  EXPECT_EQ(json["knobs"]["alpha"]["points"].size(), 3u);
  const std::string verdict = json["knobs"]["alpha"]["default_verdict"].get<std::string>();
  EXPECT_NE(verdict.find("the default (alpha=2)"), std::string::npos) << verdict;
  EXPECT_TRUE(fs::exists(dir / "sweep.html"));
  EXPECT_TRUE(fs::exists(dir / "sweep.md"));
  fs::remove_all(dir);
}

// With live frames each point also runs the live loop, with its settings
// (the knob's value and the base's), and its end-to-end time joins the
// report; a rerun keeps it, a live run that fails names its log.
TEST(Sweep, LivePointsRunTheLoopWithTheirOwnSettings) {
  const fs::path dir = fs::temp_directory_path() / "holofuse_sweep_live";
  fs::remove_all(dir);
  SweepOptions options = tinySweep(dir.string());
  options.knobs = {{"draco-bits", {"8"}}};
  options.live_frames = 3;
  options.loop_program = std::string(HOLOFUSE_BIN_DIR) + "/holofuse_loop";
  const auto points = runSweep(options).value();
  ASSERT_EQ(points.size(), 2u) << "the default joins";
  for (const auto& p : points) {
    ASSERT_TRUE(p.live.has_value()) << p.value;
    EXPECT_EQ(p.live->frames, 3);
    EXPECT_GT(p.live->end_to_end_ms_p50, 0.0);
    EXPECT_LE(p.live->end_to_end_ms_p50, p.live->end_to_end_ms_p95);
    EXPECT_TRUE(fs::exists(p.live->report)) << p.live->report;
    // Every stage the live loop stamped, for the budget, and each of the
    // scene's 4 pods' arrival jitter at the server.
    EXPECT_DOUBLE_EQ(p.live->stage_ms_p95.at("end_to_end"), p.live->end_to_end_ms_p95);
    EXPECT_GT(p.live->stage_ms_p95.count("upload"), 0u)
        << "a stage the leave-one-out run does not time";
    EXPECT_EQ(p.live->stage_ms_p95.count("replay_read"), 0u) << "not stamped in a live run";
    EXPECT_EQ(p.live->jitter_ms.size(), 4u);
  }
  // The server of each live run says what it ran with: the point's Draco
  // bits, and the base's image size reached the pods.
  const std::string eight = readText(dir / "live" / "draco-bits=8" / "logs" / "server.log");
  const std::string eleven = readText(dir / "live" / "default" / "logs" / "server.log");
  EXPECT_NE(eight.find("Draco 8 bits"), std::string::npos) << eight;
  EXPECT_NE(eleven.find("Draco 11 bits"), std::string::npos) << eleven;
  EXPECT_NE(readText(dir / "live" / "default" / "loop.log").find("4 pods at 96x72"),
            std::string::npos);
  ASSERT_TRUE(writeSweepReports(options, points).isOk());
  std::ifstream in(dir / "sweep.json");
  const auto json = nlohmann::json::parse(in);
  for (const auto& p : json["knobs"]["draco-bits"]["points"]) {
    EXPECT_EQ(p["live"]["frames"], 3) << p.dump();
    EXPECT_GT(p["live"]["end_to_end_ms_p50"].get<double>(), 0.0);
    EXPECT_GE(p["live_worst_pod_jitter_ms"].get<double>(), 0.0);
  }
  EXPECT_NE(readText(dir / "sweep.html").find("PSNR against live end-to-end ms"),
            std::string::npos);
  if (!holofuse::test::chromium().empty()) {
    EXPECT_EQ(holofuse::test::chartsRendered(dir / "sweep.html"), 6)
        << "PSNR against client ms, pipeline ms, both links' bytes and live end-to-end ms, and the "
           "latency stack";
  }

  const auto again = runSweep(options).value();
  EXPECT_TRUE(again[0].resumed && again[1].resumed);
  EXPECT_DOUBLE_EQ(again[0].live->end_to_end_ms_p50, points[0].live->end_to_end_ms_p50)
      << "kept, not run again";
  EXPECT_EQ(again[0].live->jitter_ms, points[0].live->jitter_ms);
  EXPECT_EQ(again[0].live->stage_ms_p95, points[0].live->stage_ms_p95);

  // A new point whose live run fails keeps its leave-one-out result on
  // disk; the rerun reads it back and runs only the live part.
  const std::string loop = options.loop_program;
  options.knobs = {{"draco-bits", {"14"}}};
  options.loop_program = (dir / "no-such-loop").string();
  EXPECT_FALSE(runSweep(options).isOk());
  {
    std::ifstream kept_in(dir / "points" / "draco-bits=14.json");
    const auto kept = nlohmann::json::parse(kept_in);
    EXPECT_TRUE(kept.contains("result"));
    EXPECT_FALSE(kept.contains("live"));
  }
  options.loop_program = loop;
  const auto mended = runSweep(options).value();
  ASSERT_EQ(mended.size(), 2u);
  EXPECT_TRUE(mended[0].resumed) << "the leave-one-out run is not repeated";
  ASSERT_TRUE(mended[0].live.has_value());
  EXPECT_EQ(mended[0].live->frames, 3);
  options.live_frames = 4;  // asks for another live run, which cannot start
  options.loop_program = (dir / "no-such-loop").string();
  {
    const auto refused = runSweep(options);
    EXPECT_FALSE(refused.isOk()) << "a live run that cannot start must fail the sweep";
    const std::string what = refused.isOk() ? "" : refused.status().message();
    EXPECT_NE(what.find("loop.log"), std::string::npos) << what;
  }
  fs::remove_all(dir);
}

TEST(Sweep, PointsMeasuredUnderOtherSettingsAreRefusedNotMixedIn) {
  const fs::path dir = fs::temp_directory_path() / "holofuse_sweep_settings";
  fs::remove_all(dir);
  SweepOptions options = tinySweep(dir.string());
  options.knobs = {{"alpha", {"1"}}};
  const auto first = runSweep(options).value();
  ASSERT_EQ(first.size(), 2u) << "alpha=1 and the default";
  const std::string measured = [&] {
    std::ifstream in(dir / "points" / "alpha=1.json");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  // The same folder, another image size: the point on disk is not this
  // run's, and nothing runs or changes on disk.
  options.base.width = 128;
  options.base.height = 96;
  {
    const auto refused = runSweep(options);
    ASSERT_FALSE(refused.isOk()) << "a point from another image size was reused";
    const std::string what = refused.isOk() ? "" : refused.status().message();
    EXPECT_NE(
        what.find(
            "alpha=1.json was measured under other settings: size \"96x72\" (now \"128x96\")"),
        std::string::npos)
        << what;
    EXPECT_NE(what.find("another --out"), std::string::npos) << what;
  }
  std::ifstream in(dir / "points" / "alpha=1.json");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), measured);
  // Back to the settings it was measured under: resumed.
  options.base.width = 96;
  options.base.height = 72;
  const auto again = runSweep(options).value();
  ASSERT_EQ(again.size(), 2u);
  EXPECT_TRUE(again[0].resumed && again[1].resumed);
  fs::remove_all(dir);
}

// The default's place is judged on every cost at once: a value that
// renders as fast at the same quality but sends more bytes does not beat it.
TEST(Sweep, TheDefaultIsDominatedOnlyByAPointNoWorseOnEveryCost) {
  const fs::path dir = fs::temp_directory_path() / "holofuse_sweep_verdict";
  fs::remove_all(dir);
  fs::create_directories(dir);
  SweepOptions options = tinySweep(dir.string());
  options.knobs = {{"draco-bits", {"11", "14"}}, {"alpha", {"1", "2"}}};
  std::vector<SweepPoint> points;
  auto add = [&](const std::string& knob, const std::string& value, bool is_default, double psnr,
                 double client_ms, double codec_ms, double bytes) {
    points.push_back(
        test::sweepPoint(knob, value, is_default, "normal", psnr, client_ms, codec_ms, bytes));
  };
  add("draco-bits", "11", true, 19.5, 30, 5, 1.2e6);
  add("draco-bits", "14", false, 19.5, 30, 6,
      1.3e6);                                    // as good and as fast to render, but more to send
  add("alpha", "1", false, 19.7, 30, 5, 1.2e6);  // better, at no cost
  add("alpha", "2", true, 19.5, 30, 5, 1.2e6);
  ASSERT_TRUE(writeSweepReports(options, points).isOk());
  std::ifstream in(dir / "sweep.json");
  const auto json = nlohmann::json::parse(in);
  EXPECT_EQ(json["knobs"]["draco-bits"]["default_verdict"],
            "the default (draco-bits=11) is on the Pareto front");
  EXPECT_EQ(json["knobs"]["draco-bits"]["points"][1]["on_front"], false)
      << "14 bits: dominated by 11";
  EXPECT_DOUBLE_EQ(json["knobs"]["draco-bits"]["points"][1]["pipeline_ms"].get<double>(),
                   20 + 6 + 30);
  EXPECT_EQ(json["knobs"]["alpha"]["default_verdict"],
            "the default (alpha=2) is dominated by alpha=1");
  EXPECT_EQ(json["knobs"]["alpha"]["points"][0]["live_command"],
            "./holofuse demo --scene few-cameras --mode normal --size 96x72 --alpha 1")
      << "the base's size (96x72) goes with it";
  EXPECT_EQ(json["knobs"]["draco-bits"]["points"][1]["live_command"],
            "./holofuse demo --scene few-cameras --mode normal --size 96x72 --draco-bits 14");
  fs::remove_all(dir);
}

// A sweep of mode layered is read against the camera images: with mode
// normal asked for too, the report gives normal's quality and bytes at the
// default point beside the knob's table (the images' 577 KB and 19.57 dB
// here stand for what eval measures on clean).
TEST(Sweep, TheOtherModesAreGivenBesideTheDefault) {
  const fs::path dir = fs::temp_directory_path() / "holofuse_sweep_beside";
  fs::remove_all(dir);
  fs::create_directories(dir);
  SweepOptions options = tinySweep(dir.string());
  options.base.modes = {render::BlendMode::kNormal, render::BlendMode::kLayered};
  options.knobs = {{"layers", {"1", "3"}}};
  std::vector<SweepPoint> points = {
      test::sweepPoint("layers", "1", false, "layered", 19.2, 25, 5, 5.8e5),
      test::sweepPoint("layers", "3", true, "layered", 19.3, 30, 5, 5.8e5)};
  for (SweepPoint& p : points) {
    p.result.modes.at("layered").client_bytes_per_frame = p.value == "1" ? 3.8e5 : 9.5e5;
    ModeResult& normal = p.result.modes["normal"];
    normal.psnr_db = 19.57;
    normal.ssim = 0.6884;
  }
  ASSERT_TRUE(writeSweepReports(options, points).isOk());
  std::ifstream in(dir / "sweep.json");
  const auto json = nlohmann::json::parse(in);
  EXPECT_EQ(json["quality_mode"], "layered");
  ASSERT_TRUE(json["other_modes_at_default"].contains("normal")) << json.dump();
  EXPECT_FALSE(json["other_modes_at_default"].contains("layered"));
  EXPECT_DOUBLE_EQ(json["other_modes_at_default"]["normal"]["bytes_per_frame"].get<double>(), 5.8e5)
      << "mode normal's link carries the scene's images";
  EXPECT_DOUBLE_EQ(json["knobs"]["layers"]["points"][1]["bytes_per_frame"].get<double>(), 9.5e5);
  EXPECT_NE(readText(dir / "sweep.md")
                .find("at the default point: `normal` 19.57 dB PSNR, SSIM 0.6884, 580 KB/frame"),
            std::string::npos)
      << readText(dir / "sweep.md");
  fs::remove_all(dir);
}

// Runs command; its output (stdout and stderr) and pclose's status (-1 when
// it could not start).
std::string run(const std::string& command, int* status) {
  std::string output;
  *status = -1;
  std::FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return output;
  char buffer[4096];
  for (size_t n; (n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0;) output.append(buffer, n);
  *status = pclose(pipe);
  return output;
}

// Killed for real in the middle of a sweep (SIGKILL, no chance to tidy
// up), the finished points stay on disk and the rerun of the same command
// skips them; a scene the library does not have is refused naming those it has.
TEST(Sweep, AKilledSweepResumesWhereItStopped) {
  const fs::path dir = holofuse::test::freshDir("sweep_killed");
  // Six points of a second or so each: the kill lands long before the last.
  const std::vector<std::string> command = {std::string(HOLOFUSE_BIN_DIR) + "/holofuse_sweep",
                                            "--scene",
                                            "few-cameras",
                                            "--modes",
                                            "normal",
                                            "--frames",
                                            "2",
                                            "--held-out",
                                            "2",
                                            "--set",
                                            "size=160x120",
                                            "--knob",
                                            "alpha=1,4,8,16,32",
                                            "--out",
                                            dir.string()};
  const pid_t sweep = holofuse::test::spawn(command, dir / "first.log");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  bool exited = false;
  while (!fs::exists(dir / "points" / "alpha=1.json") &&
         std::chrono::steady_clock::now() < deadline && !exited) {
    exited = waitpid(sweep, nullptr, WNOHANG) == sweep;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (!exited) {
    kill(sweep, SIGKILL);
    EXPECT_EQ(holofuse::test::waitExit(sweep, 30), 128 + SIGKILL) << "killed before it finished";
  }
  ASSERT_FALSE(exited) << "the sweep ended before its first point: " << readText(dir / "first.log");
  ASSERT_TRUE(fs::exists(dir / "points" / "alpha=1.json")) << readText(dir / "first.log");
  EXPECT_FALSE(fs::exists(dir / "sweep.json"));
  size_t on_disk = 0;
  for (const auto& entry : fs::directory_iterator(dir / "points"))
    on_disk += entry.path().extension() == ".json";
  EXPECT_LT(on_disk, 6u) << "some points were still to run";
  const std::string measured = readText(dir / "points" / "alpha=1.json");
  std::string joined;
  for (const auto& part : command) joined += "'" + part + "' ";
  int status = 0;
  const std::string output = run(joined, &status);
  ASSERT_EQ(status, 0) << output;
  EXPECT_NE(output.find("alpha=1 (already on disk)"), std::string::npos) << output;
  EXPECT_NE(output.find("[6/6] alpha=2"), std::string::npos) << "the default joins: " << output;
  EXPECT_EQ(readText(dir / "points" / "alpha=1.json"), measured) << "read back, not measured again";
  std::ifstream in(dir / "sweep.json");
  EXPECT_EQ(nlohmann::json::parse(in)["knobs"]["alpha"]["points"].size(), 6u);

  const std::string refused =
      run(std::string(HOLOFUSE_BIN_DIR) + "/holofuse_sweep --scene nowhere --knob alpha=1 --out " +
              dir.string(),
          &status);
  EXPECT_EQ(WEXITSTATUS(status), 2) << refused;
  EXPECT_NE(refused.find("unknown scene 'nowhere'; valid scenes: clean, calibration-error"),
            std::string::npos)
      << refused;
  fs::remove_all(dir);
}

// --set moves the base every point starts from: the points are measured
// at it, and their live commands carry it.
TEST(Sweep, SetMovesTheBaseOfEveryPoint) {
  const fs::path dir = fs::temp_directory_path() / "holofuse_sweep_set";
  fs::remove_all(dir);
  const std::string sweep = std::string(HOLOFUSE_BIN_DIR) +
                            "/holofuse_sweep --scene few-cameras --modes normal "
                            "--frames 1 --held-out 1 --out " +
                            dir.string();
  int status = 0;
  std::string output = run(sweep + " --set brightness=2 --knob alpha=1", &status);
  EXPECT_EQ(WEXITSTATUS(status), 2) << output;
  EXPECT_NE(output.find("knobs: voxel"), std::string::npos) << output;
  output = run(sweep + " --set size=96x7 --knob alpha=1", &status);
  EXPECT_EQ(WEXITSTATUS(status), 2) << output;
  EXPECT_NE(output.find("--set size: '96x7'"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(dir / "points")) << "refused before any work";
  output = run(sweep + " --set size=96x72 --set draco-bits=9 --knob alpha=1", &status);
  ASSERT_EQ(status, 0) << output;
  std::ifstream in(dir / "sweep.json");
  const auto json = nlohmann::json::parse(in);
  const auto& point = json["knobs"]["alpha"]["points"][0];
  std::ifstream point_file(dir / "points" / "alpha=1.json");
  EXPECT_EQ(nlohmann::json::parse(point_file)["settings"]["size"], "96x72")
      << "measured at the base's size";
  EXPECT_EQ(point["live_command"],
            "./holofuse demo --scene few-cameras --mode normal --draco-bits 9 --size 96x72 "
            "--alpha 1");
  EXPECT_EQ(json["knobs"]["alpha"]["points"][1]["value"], "2") << "the default, added";
  fs::remove_all(dir);
}

// Eval's command line sets a resolution and the pods' crop margin, as the
// loop's flags do, and the report says what it ran with.
TEST(Sweep, EvalTakesTheVoxelAndTheCropMarginLikeTheLoop) {
  const fs::path dir = fs::temp_directory_path() / "holofuse_eval_flags";
  fs::remove_all(dir);
  const std::string eval = std::string(HOLOFUSE_BIN_DIR) +
                           "/holofuse_eval --scenes few-cameras --modes normal "
                           "--frames 1 --held-out 1 --size 96x72 ";
  int status = 0;
  std::string output =
      run(eval + "--voxel 0.03 --crop-margin -1 --out " + (dir / "whole").string(), &status);
  ASSERT_EQ(status, 0) << output;
  output = run(eval + "--out " + (dir / "cropped").string(), &status);
  ASSERT_EQ(status, 0) << output;
  auto read = [&](const char* run_name) {
    std::ifstream in(dir / run_name / "quality.json");
    return nlohmann::json::parse(in);
  };
  const auto whole = read("whole"), cropped = read("cropped");
  EXPECT_DOUBLE_EQ(whole["settings"]["voxel_size"].get<double>(), 0.03);
  EXPECT_EQ(whole["settings"]["crop_margin"], -1);
  EXPECT_DOUBLE_EQ(whole["scenes"]["few-cameras"]["hull"]["voxel_mm"].get<double>(), 30.0);
  EXPECT_EQ(cropped["settings"]["crop_margin"], 8) << "the pods' own default";
  EXPECT_GT(whole["scenes"]["few-cameras"]["pod_link_bytes_per_frame"].get<double>(),
            1.5 * cropped["scenes"]["few-cameras"]["pod_link_bytes_per_frame"].get<double>())
      << "whole images cost the pod link more than the subject's rectangle";
  output = run(eval + "--crop-margin -2 --out " + (dir / "bad").string(), &status);
  EXPECT_EQ(WEXITSTATUS(status), 2);
  EXPECT_NE(output.find("--crop-margin"), std::string::npos) << output;
  fs::remove_all(dir);
}

// Every knob can be set in the live loop: its flag is one of the
// launcher's (tests/integration/test_loop.cpp runs the loop with them),
// and one of eval's (but --size, which eval has of its own).
TEST(Sweep, EveryKnobIsAFlagOfTheLiveLoopAndOfEval) {
  for (const char* program : {"holofuse_loop", "holofuse_eval"}) {
    int status = -1;
    const std::string help =
        run(std::string(HOLOFUSE_BIN_DIR) + "/" + program + " --help", &status);
    ASSERT_EQ(status, 0) << help;
    for (const Knob& knob : sweepKnobs()) {
      ASSERT_FALSE(knob.loop_flag.empty()) << knob.name;
      EXPECT_NE(help.find("  " + knob.loop_flag + " "), std::string::npos)
          << program << ": " << knob.name << ": " << knob.loop_flag;
    }
  }
}

// Eval's flags set what the sweep's knobs set, and refuse what they refuse,
// naming the flag.
TEST(Sweep, EvalFlagsSetWhatTheKnobsSet) {
  CLI::App app;
  const SettingFlags<EvalOptions> flags(app, evalFlags());
  EXPECT_EQ(app.get_option_no_throw("--size"), nullptr) << "eval's own";
  app.parse(
      "--vote-delta 0.3 --dilation 2 --geodesic-rings 7 --voxel 0.04 --hull-error-mm 1.5 --lambda "
      "0.2 --lz4-hc-level 3",
      false);
  EvalOptions options;
  flags.apply(options);
  const render::BlendSettings& blend = options.loop.render.blend;
  EXPECT_FLOAT_EQ(blend.fields.vote_delta, 0.3f);
  EXPECT_EQ(blend.fields.dilation_px, 2);
  EXPECT_EQ(blend.fields.geodesic_rings, 7);
  EXPECT_DOUBLE_EQ(options.loop.fusion.hull.voxel_size, 0.04);
  EXPECT_FALSE(options.voxel_from_dataset) << "a voxel given overrides a dataset's own";
  EXPECT_DOUBLE_EQ(options.loop.fusion.hull_error_target, 0.0015);
  EXPECT_DOUBLE_EQ(blend.lambda, 0.2);
  EXPECT_EQ(options.loop.fusion.lz4_hc_level, 3);
  EXPECT_EQ(options.loop.pods.lz4_hc_level, 3) << "one flag for the pods and the server";
  EXPECT_EQ(blend.alpha, EvalOptions{}.loop.render.blend.alpha)
      << "a flag not given leaves its setting alone";
  CLI::App bad_app;
  const SettingFlags<EvalOptions> bad(bad_app, evalFlags());
  try {
    bad_app.parse("--dilation 65", false);
    ADD_FAILURE() << "--dilation 65 was taken";
  } catch (const CLI::ValidationError& e) {
    const std::string error = e.what();
    EXPECT_NE(error.find("--dilation"), std::string::npos) << error;
    EXPECT_NE(error.find("65"), std::string::npos) << error;
  }
}

// A dataset carves at the voxel it was imported with unless one is given,
// in eval and in a sweep, whose default point is the dataset's own voxel;
// a sweep over a dataset refuses the knobs only a synthetic scene has.
TEST(Sweep, ADatasetIsSweptAroundItsOwnSettings) {
  const fs::path dir = fs::temp_directory_path() / "holofuse_sweep_dataset";
  fs::remove_all(dir);
  const fs::path capture = dir / "capture";
  test::writeSmallDataset(capture, 4, 96, 72, 0.03);
  EvalOptions eval = tinySweep("").base;
  eval.scenes.clear();
  eval.datasets = {capture.string()};
  EXPECT_DOUBLE_EQ(runLeaveOneOut(eval).value().at(0).voxel_mm, 30.0) << "the dataset's own voxel";
  ASSERT_EQ(findKnob("voxel")->apply(eval, "0.05"), "");
  EXPECT_DOUBLE_EQ(runLeaveOneOut(eval).value().at(0).voxel_mm, 50.0) << "the voxel given";

  SweepOptions options = tinySweep((dir / "sweep").string());
  options.base.scenes.clear();
  options.base.datasets = {capture.string()};
  options.knobs = {{"voxel", {"0.05"}}};
  const auto points = runSweep(options).value();
  ASSERT_EQ(points.size(), 2u) << "the value asked for and the default";
  EXPECT_EQ(points[0].result.name, "dataset:capture");
  EXPECT_DOUBLE_EQ(points[0].result.voxel_mm, 50.0);
  EXPECT_TRUE(points[1].is_default);
  EXPECT_EQ(points[1].value, "0.03") << "the dataset's voxel is the default";
  EXPECT_DOUBLE_EQ(points[1].result.voxel_mm, 30.0);
  ASSERT_TRUE(writeSweepReports(options, points).isOk());
  std::ifstream in(dir / "sweep" / "sweep.json");
  const auto json = nlohmann::json::parse(in);
  EXPECT_EQ(json["dataset"], capture.string());
  EXPECT_NE(json["knobs"]["voxel"]["points"][0]["live_command"].get<std::string>().find(
                "--replay " + capture.string()),
            std::string::npos)
      << "a dataset's point runs live as a replay";
  for (const char* knob : {"cameras", "size"}) {
    options.knobs = {{knob, {knob == std::string("size") ? "64x48" : "3"}}};
    {
      const auto refused = runSweep(options);
      EXPECT_FALSE(refused.isOk()) << knob << " was taken for a dataset";
      const std::string what = refused.isOk() ? "" : refused.status().message();
      EXPECT_NE(what.find("needs a synthetic scene"), std::string::npos) << what;
    }
  }
  fs::remove_all(dir);
}

// A value the live loop takes, the sweep takes, and the reverse: a knob
// of a loop flag has that flag's range or choices.
TEST(Sweep, KnobsTakeExactlyWhatTheirLoopFlagTakes) {
  int shared = 0;
  for (const Knob& knob : sweepKnobs()) {
    const Setting<LoopSettings>* flag = findSetting(loopFlags(), knob.loop_flag);
    if (flag == nullptr) continue;
    ++shared;
    EvalOptions options;
    if (!flag->choices.empty()) {
      for (const std::string& choice : flag->choices)
        EXPECT_EQ(knob.apply(options, choice), "") << knob.name;
      EXPECT_NE(knob.apply(options, "none-of-them"), "") << knob.name;
      continue;
    }
    auto text = [](double v) {
      char buffer[32];
      std::snprintf(buffer, sizeof(buffer), "%.9g", v);
      return std::string(buffer);
    };
    // A whole-number knob is probed a whole step beyond each end: a
    // fraction would be refused as a fraction whatever the range.
    const bool whole =
        knob.apply(options, text(flag->min + 0.5)).find("whole number") != std::string::npos;
    const double step = whole ? 1.0 : std::max(1.0, flag->max - flag->min) * 1e-3;
    for (const double v : {flag->min, flag->max}) {
      EXPECT_EQ(knob.apply(options, text(v)), "") << knob.name << " " << v;
    }
    for (const double v : {flag->min - step, flag->max + step}) {
      const std::string error = knob.apply(options, text(v));
      EXPECT_NE(error, "") << knob.name << " " << v;
      EXPECT_EQ(error.find("whole number"), std::string::npos)
          << knob.name << ": refused for its range, " << error;
    }
  }
  EXPECT_EQ(shared, static_cast<int>(sweepKnobs().size()) - 2)
      << "all but cameras (2 at least) and size";
}

TEST(Sweep, KnobsChangeWhatTheyName) {
  EvalOptions options;
  EXPECT_EQ(findKnob("voxel")->apply(options, "0.03"), "");
  EXPECT_DOUBLE_EQ(options.loop.fusion.hull.voxel_size, 0.03);
  EXPECT_EQ(findKnob("K")->apply(options, "12"), "");
  EXPECT_EQ(options.loop.render.blend.fields.geodesic_iterations, 12);
  EXPECT_NE(findKnob("K")->apply(options, "12.5"), "") << "passes are whole";
  EXPECT_EQ(findKnob("image-codec")->apply(options, "raw"), "");
  EXPECT_EQ(options.loop.fusion.image_codec, protocol::Codec::kRaw);
  EXPECT_EQ(options.loop.pods.color_codec, protocol::Codec::kRaw) << "pods and server alike";
  EXPECT_EQ(findKnob("size")->apply(options, "640x480"), "");
  EXPECT_EQ(findKnob("size")->current(options), "640x480");
  EXPECT_EQ(findKnob("nonsense"), nullptr);
}

}  // namespace
}  // namespace holofuse::eval
