// The HTML reports open in a real browser (browser_check.h): headless
// Chromium loads each page and the test reads back how many charts it
// rendered faithfully. Also the numbers behind the loop report: RFC 3550
// jitter and budgets.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>

#include "base/arrival_jitter.h"
#include "base/statistics.h"
#include "browser_check.h"
#include "eval/leave_one_out.h"
#include "eval/sweep.h"
#include "report/html.h"
#include "report/latency_report.h"
#include "sweep_points.h"

namespace holofuse {
namespace {

namespace fs = std::filesystem;

using test::chartsRendered;
using test::chromium;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("holofuse_html_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(HtmlReports, ChartsRenderInChromiumAndAnEmptyChartDoesNotCount) {
  if (chromium().empty()) GTEST_SKIP() << "chromium is not installed (./holofuse deps installs it)";
  const fs::path dir = scratch("charts");
  const std::string faithful =
      html::barChart("PSNR", {"clean", "few-cameras"},
                     {{"normal", {17.0, 11.2}}, {"montage4d", {17.3, 11.4}}}, "dB") +
      html::stackedBars(
          "Latency", {"hull", "render"},
          {{"p50", {30, 40}, 95.0, "end to end p95"}, {"p50 again", {20, 10}, std::nullopt, ""}},
          "ms") +
      html::scatterChart("Trade", "ms", "dB",
                         {{"a", 10, 19.0, true, false}, {"b", 30, 19.6, true, true}});
  std::ofstream(dir / "page.html")
      << html::page("test", faithful + html::barChart("Nothing", {}, {}, "ms"));
  EXPECT_EQ(chartsRendered(dir / "page.html"), 3) << "no bars: the empty chart does not count";
  // Charts whose marks do not sit where their values say do not count: a
  // bar drawn twice as long as its value, a point drawn on the wrong side.
  auto swap = [](std::string text, const std::string& from, const std::string& to) {
    const size_t at = text.find(from);
    return at == std::string::npos ? std::string() : text.replace(at, from.size(), to);
  };
  const std::string bars =
      html::barChart("PSNR", {"clean"}, {{"normal", {10.0}}, {"montage4d", {20.0}}}, "dB");
  const std::string scatter = html::scatterChart(
      "Trade", "ms", "dB", {{"a", 10, 19.0, false, false}, {"b", 30, 19.6, false, false}});
  const std::string wrong_bar = swap(bars, "data-value=\"10\"", "data-value=\"5\"");
  const std::string wrong_point = swap(scatter, "data-y=\"19\"", "data-y=\"20\"");
  ASSERT_FALSE(wrong_bar.empty());
  ASSERT_FALSE(wrong_point.empty());
  std::ofstream(dir / "wrong.html") << html::page("test", bars + scatter + wrong_bar + wrong_point);
  EXPECT_EQ(chartsRendered(dir / "wrong.html"), 2) << "only the two faithful charts";
  // A value not measured (NaN) is drawn as "n/a", not as a bar.
  const std::string unmeasured =
      html::barChart("Flicker", {"clean"}, {{"normal", {std::nan("")}}, {"montage4d", {2.0}}}, "g");
  EXPECT_EQ(unmeasured.find("data-value=\"0\""), std::string::npos);
  EXPECT_NE(unmeasured.find(">n/a<"), std::string::npos);
  fs::remove_all(dir);
}

TEST(HtmlReports, LoopReportShowsBudgetJitterAndBytes) {
  if (chromium().empty()) GTEST_SKIP() << "chromium is not installed (./holofuse deps installs it)";
  report::LatencyReport report;
  for (uint64_t f = 0; f < 10; ++f) {
    const uint64_t t = f * 100'000'000;
    report.addStamps(
        {{static_cast<uint16_t>(protocol::Stage::kHull), protocol::kSourceServer, t,
          t + 40'000'000},
         {static_cast<uint16_t>(protocol::Stage::kSend), 0, t, t + 2'000'000 + (f % 2) * 1'000'000},
         {static_cast<uint16_t>(protocol::Stage::kSend), 1, t, t + 3'000'000}});
    report.addGpuPass("geodesics", 60.0);
    report::FrameRecord record;
    record.frame_id = f;
    record.end_to_end_ms = 200;
    record.pod_bytes = 600'000;
    record.client_bytes = 650'000;
    if (f != 3) {  // a frame not judged does not count
      record.quality =
          report::FrameQuality{20.0 + static_cast<double>(f), 0.5 + 0.01 * static_cast<double>(f)};
    }
    report.addFrame(record, t);
  }
  // The quality table: 9 frames judged, PSNR 20..29 but 23, SSIM alike.
  const auto quality = report.quality();
  ASSERT_EQ(quality.size(), 2u);
  EXPECT_EQ(quality[0].frames, 9u);
  EXPECT_NEAR(quality[0].mean, (20 + 21 + 22 + 24 + 25 + 26 + 27 + 28 + 29) / 9.0, 1e-12);
  EXPECT_DOUBLE_EQ(quality[0].p50, 25.0);
  EXPECT_DOUBLE_EQ(quality[0].worst, 20.0);
  EXPECT_DOUBLE_EQ(quality[1].worst, 0.5);
  // replay_read: a stage this (live) run never stamped.
  const protocol::Budget budget = {{"hull", 30.0}, {"end_to_end", 500.0}, {"replay_read", 0.001}};
  const fs::path dir = scratch("loop");
  std::ofstream(dir / "report.html") << report.toHtml({{"mode", "montage4d"}}, budget);
  // Latency stages, GPU passes, bytes per link, jitter.
  EXPECT_EQ(chartsRendered(dir / "report.html"), 4);
  std::ifstream in(dir / "report.html");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("<tr class=\"flagged\"><td>hull</td>"), std::string::npos)
      << "hull p95 40 ms > 30 ms budget";
  EXPECT_EQ(text.find("<tr class=\"flagged\"><td>end_to_end</td>"), std::string::npos);
  EXPECT_NE(
      text.find("<tr><td>replay_read</td><td>0.0 ms</td><td>n/a</td><td>n/a</td><td>not measured"),
      std::string::npos)
      << "a stage without samples is neither within nor over";
  EXPECT_NE(
      text.find(
          "<tr><td>PSNR</td><td>24.67 dB</td><td>25.00 dB</td><td>20.00 dB</td><td>9</td></tr>"),
      std::string::npos)
      << "the quality table";
  const auto json = nlohmann::json::parse(report.toJson({}, budget));
  ASSERT_EQ(json["budget_violations"].size(), 1u);
  EXPECT_EQ(json["budget_violations"][0]["stage"], "hull");
  EXPECT_EQ(json["budget_unmeasured"], (nlohmann::json{"replay_read"}));
  EXPECT_DOUBLE_EQ(json["quality"]["ssim"]["worst"].get<double>(), 0.5);
  EXPECT_TRUE(json["frames"][3]["psnr_db"].is_null());
  fs::remove_all(dir);
}

// Each stacked chart's segments as name -> colours, from the SVG as a
// browser reads it: a bar's fill and its tooltip's name.
std::map<std::string, std::set<std::string>> segmentColours(const fs::path& page) {
  std::ifstream in(page);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::map<std::string, std::set<std::string>> colours;
  const std::regex bar(R"re(data-encoding="width"[^>]*fill="(#[0-9a-f]{6})"><title>([^:<]+):)re");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), bar); it != std::sregex_iterator();
       ++it)
    colours[(*it)[2]].insert((*it)[1]);
  return colours;
}

std::string readText(const fs::path& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The live report and the evaluation's page read apart: one colour per
// stage in every chart (the slowest frames' chart leaves out stages no
// slow frame ran, which once shifted every colour after them), the p95s
// never stacked, frames named by their place in the run, the settings in
// a table of their own, start-up frames not counted as bad input, and no
// table without rows.
TEST(HtmlReports, EachStageKeepsOneColourInEveryChartAndNoPercentileIsStacked) {
  using protocol::Stage;
  report::LatencyReport report;
  const uint64_t first_id = 26'946'885'960;
  for (uint64_t f = 0; f < 6; ++f) {
    const uint64_t t = 1'000'000'000 + f * 100'000'000;
    const auto stamp = [&](Stage stage, uint64_t from_ms, uint64_t to_ms) {
      return protocol::StageStamp{static_cast<uint16_t>(stage), protocol::kSourceServer,
                                  t + from_ms * 1'000'000, t + to_ms * 1'000'000};
    };
    // Only the fastest frame is refined: the chart of the five slowest
    // lacks refine, and the stages after it must keep their colours.
    std::vector<protocol::StageStamp> stamps = {
        stamp(Stage::kHull, 0, 30), stamp(Stage::kMeshEncode, 30, 40),
        stamp(Stage::kDecode, 45, 50), stamp(Stage::kUpload, 50, 55),
        stamp(Stage::kRender, 55, 70 + 10 * f)};
    if (f == 0) stamps.push_back(stamp(Stage::kRefine, 40, 45));
    report.addStamps(stamps);
    report::FrameRecord record;
    record.frame_id = first_id + f;
    record.capture_time_ns = t;
    record.end_to_end_ms = static_cast<double>(80 + 10 * f);
    record.timeline = stamps;
    report.addFrame(record, t);
  }
  report.noteStartUp("frame 1: no texture layers yet");
  report.startUpEnded();
  const fs::path dir = scratch("colours");
  std::ofstream(dir / "report.html") << report.toHtml({{"mode", "layered"}}, {});

  eval::SceneResult scene;
  scene.name = "clean";
  scene.cameras = 4;
  scene.modes["normal"] = {15.2, 16.7, 0.59, 19.2, 21.0, 16, 80, {}, 95, {}};
  scene.hull_ms = scene.codec_ms = 20;
  for (const std::string& stage : eval::codecStages())
    scene.codec_stage_ms[stage] = scene.codec_stage_ms_p95[stage] = 3;
  eval::EvalOptions options;
  options.modes = {render::BlendMode::kNormal};
  ASSERT_TRUE(eval::writeQualityReports(options, {scene}, dir.string()).isOk());

  std::map<std::string, std::set<std::string>> colours;
  for (const char* page : {"report.html", "quality.html"}) {
    for (const auto& [stage, used] : segmentColours(dir / page))
      colours[stage == "client render" ? "render" : stage].insert(used.begin(), used.end());
  }
  for (const char* stage : {"hull", "refine", "mesh_encode", "decode", "upload", "render"})
    ASSERT_EQ(colours.count(stage), 1u) << stage << " is drawn nowhere";
  std::map<std::string, std::string> owner;
  for (const auto& [stage, used] : colours) {
    EXPECT_EQ(used.size(), 1u) << stage << " is drawn in " << ::testing::PrintToString(used);
    const auto [it, fresh] = owner.emplace(*used.begin(), stage);
    EXPECT_TRUE(fresh) << stage << " and " << it->second << " share " << *used.begin();
  }

  const std::string page = readText(dir / "report.html");
  // The budget chart: one row of p50s, the end to end's p95 a mark.
  EXPECT_EQ(page.find(">p95</text>"), std::string::npos) << "a stacked row of p95s";
  EXPECT_NE(page.find("<line class=\"mark\""), std::string::npos);
  // 80..130 ms: a p95 of 127.5, beside the row's total.
  EXPECT_NE(page.find("; end to end p95 128 ms</text>"), std::string::npos);
  EXPECT_NE(page.find(">frame 5</text>"), std::string::npos) << "the slowest, by its place";
  EXPECT_EQ(page.find(std::to_string(first_id)), std::string::npos) << "a frame by its id";
  const size_t settings = page.find("<h2>Settings</h2>");
  ASSERT_NE(settings, std::string::npos);
  EXPECT_GT(page.find("<td>mode</td>", 0), settings) << "a setting among the results";
  EXPECT_NE(page.find("frames at start-up"), std::string::npos);
  EXPECT_EQ(page.find("frames skipped"), std::string::npos) << "nothing was skipped";
  const auto json = nlohmann::json::parse(report.toJson({}, {}));
  EXPECT_EQ(json["frames_at_start_up"].size(), 1u);
  EXPECT_EQ(json["frames_skipped"].size(), 0u);
  // A start-up that never ended: the frames were skipped after all.
  report::LatencyReport never;
  never.noteStartUp("frame 1: no texture layers yet");
  const auto never_json = nlohmann::json::parse(never.toJson({}, {}));
  EXPECT_EQ(never_json["frames_at_start_up"].size(), 0u);
  EXPECT_EQ(never_json["frames_skipped"].size(), 1u);

  // Holoportation did not run: no verdict table against it.
  const std::string quality = readText(dir / "quality.html");
  EXPECT_EQ(quality.find("montage4d against holoportation"), std::string::npos);
  EXPECT_EQ(quality.find("<tbody></tbody>"), std::string::npos) << "an empty table";
  fs::remove_all(dir);
}

TEST(HtmlReports, QualityPageChartsEveryMetric) {
  if (chromium().empty()) GTEST_SKIP() << "chromium is not installed (./holofuse deps installs it)";
  eval::SceneResult scene;
  scene.name = "colour-imbalance";
  scene.cameras = 8;
  scene.modes["holoportation"] = {15.2, 16.7, 0.59, 19.2, 21.0, 16, 80, {}, 95, {}};
  scene.modes["montage4d"] = {15.0, 16.9, 0.60, 18.0, 20.5, 16, 120, {}, 150, {}};
  scene.hull_ms = scene.codec_ms = 20;
  scene.hull_ms_p95 = scene.codec_ms_p95 = 30;
  scene.codec_stage_ms = {{"pod_encode", 2},
                          {"server_decode", 3},
                          {"mesh_encode", 4},
                          {"image_encode", 8},
                          {"decode", 3}};
  scene.codec_stage_ms_p95 = {{"pod_encode", 3},
                              {"server_decode", 4},
                              {"mesh_encode", 5},
                              {"image_encode", 12},
                              {"decode", 6}};
  eval::EvalOptions options;
  options.modes = {render::BlendMode::kHoloportation, render::BlendMode::kMontage4D};
  // Over: the hull's p95 (30), montage4d's render (150) and the server's
  // image encoding (12); the pods' encoding (3) is within.
  options.budget = {{"hull", 25.0},         {"render", 100.0},
                    {"image_encode", 10.0}, {"pod_encode", 5.0},
                    {"end_to_end", 1.0},    {"upload", 0.001}};  // the last two: not timed by eval
  const fs::path dir = scratch("quality");
  ASSERT_TRUE(eval::writeQualityReports(options, {scene}, dir.string()).isOk());
  EXPECT_EQ(chartsRendered(dir / "quality.html"), 6)
      << "PSNR, SSIM, flicker, seam visibility, time, the latency stack";
  std::ifstream in(dir / "quality.html");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("MISSED: PSNR gain below 0.5 dB"), std::string::npos);
  EXPECT_NE(text.find(html::escape(eval::kNoJitterHere)), std::string::npos)
      << "says why there is no jitter";
  EXPECT_NE(text.find("Latency of a new mesh: colour-imbalance"), std::string::npos);
  EXPECT_NE(text.find("<tr class=\"flagged\"><td>colour-imbalance</td><td>-</td><td>hull</td>"),
            std::string::npos);
  EXPECT_NE(
      text.find("<tr class=\"flagged\"><td>colour-imbalance</td><td>montage4d</td><td>render</td>"),
      std::string::npos);
  EXPECT_NE(text.find("<tr><td>colour-imbalance</td><td>holoportation</td><td>render</td>"),
            std::string::npos)
      << "95 ms is within 100";
  EXPECT_NE(
      text.find("<tr class=\"flagged\"><td>colour-imbalance</td><td>-</td><td>image_encode</td>"),
      std::string::npos);
  EXPECT_NE(text.find("<tr><td>colour-imbalance</td><td>-</td><td>pod_encode</td>"),
            std::string::npos);
  std::ifstream json_in(dir / "quality.json");
  const auto json = nlohmann::json::parse(json_in);
  EXPECT_EQ(json["budget_violations"].size(), 3u);
  EXPECT_DOUBLE_EQ(json["budget_ms"]["hull"].get<double>(), 25.0);
  EXPECT_EQ(json["budget_unchecked"], (nlohmann::json{"end_to_end", "upload"}));
  EXPECT_NE(text.find("not checked (the live loop's report checks them): end_to_end, upload"),
            std::string::npos)
      << "stages eval does not time are named";
  EXPECT_DOUBLE_EQ(
      json["scenes"]["colour-imbalance"]["codec_stages_ms"]["image_encode"]["p95"].get<double>(),
      12.0);
  fs::remove_all(dir);
}

// The sweep's page: per knob, quality against client ms, pipeline ms and
// bytes per frame as scatter plots, with where the default stands.
TEST(HtmlReports, SweepPagePlotsEachKnobsTrade) {
  if (chromium().empty()) GTEST_SKIP() << "chromium is not installed (./holofuse deps installs it)";
  eval::SweepOptions options;
  options.base.scenes = {"clean"};
  options.base.modes = {render::BlendMode::kMontage4D};
  options.knobs = {{"alpha", {"1", "2", "8"}}, {"voxel", {"0.02", "0.01"}}};
  // render: over only at voxel 0.01 (p95 68.75 ms); end_to_end: measured
  // only where a point ran live (voxel), over at 0.01.
  options.base.budget = {{"render", 60.0}, {"end_to_end", 300.0}};
  std::vector<eval::SweepPoint> points;
  auto add = [&](const std::string& knob, const std::string& value, bool is_default, double psnr,
                 double ms, double bytes) {
    points.push_back(
        eval::test::sweepPoint(knob, value, is_default, "montage4d", psnr, ms, 5, bytes));
  };
  add("alpha", "1", false, 19.4, 30, 1.3e6);
  add("alpha", "2", true, 19.5, 30, 1.3e6);
  add("alpha", "8", false, 19.2, 31, 1.3e6);
  add("voxel", "0.02", true, 19.5, 30, 1.3e6);
  add("voxel", "0.01", false, 20.1, 55, 1.9e6);
  for (auto& p : points) {
    if (p.knob != "voxel") continue;
    const bool fine = p.value == "0.01";
    eval::LiveMeasure live;
    live.frames = 20;
    live.end_to_end_ms_p50 = fine ? 380 : 240;
    live.end_to_end_ms_p95 = fine ? 420 : 280;
    live.stage_ms_p95 = {{"end_to_end", live.end_to_end_ms_p95}, {"upload", 4.0}};
    live.jitter_ms = {{"pod_0", 0.5}, {"pod_1", fine ? 3.25 : 1.5}};
    p.live = live;
  }
  const fs::path dir = scratch("sweep");
  options.out_dir = dir.string();
  ASSERT_TRUE(eval::writeSweepReports(options, points).isOk());
  EXPECT_EQ(chartsRendered(dir / "sweep.html"), 11)
      << "four plots and the latency stack for each of two knobs, and the live end-to-end plot of "
         "the knob run live";
  std::ifstream in(dir / "sweep.html");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("the default (alpha=2) is on the Pareto front"), std::string::npos);
  EXPECT_NE(text.find("<tr class=\"flagged\"><td>voxel</td><td>0.01</td>"), std::string::npos);
  EXPECT_NE(text.find("<tr><td>voxel</td><td>0.02 (default)</td>"), std::string::npos)
      << "within budget";
  EXPECT_NE(text.find("render 68.8 &gt; 60.0 ms, live end_to_end 420.0 &gt; 300.0 ms"),
            std::string::npos);
  EXPECT_NE(text.find("Not checked at some points (no live run, or no sample in it): end_to_end."),
            std::string::npos);
  EXPECT_NE(text.find("<td>240 (p95 280)</td><td>1.50</td>"), std::string::npos)
      << "the worst pod's jitter";
  std::ifstream json_in(dir / "sweep.json");
  const auto json = nlohmann::json::parse(json_in);
  const auto& fine = json["knobs"]["voxel"]["points"][1];
  ASSERT_EQ(fine["budget_violations"].size(), 2u);
  EXPECT_EQ(fine["budget_violations"][1]["stage"], "end_to_end");
  EXPECT_EQ(fine["budget_violations"][1]["measured"], "live loop");
  EXPECT_DOUBLE_EQ(fine["live_worst_pod_jitter_ms"].get<double>(), 3.25);
  EXPECT_EQ(json["knobs"]["voxel"]["points"][0]["budget_violations"].size(), 0u);
  EXPECT_EQ(json["knobs"]["alpha"]["points"][0]["budget_unchecked"],
            (nlohmann::json{"end_to_end"}));
  EXPECT_TRUE(json["knobs"]["alpha"]["points"][0]["live_worst_pod_jitter_ms"].is_null());
  EXPECT_EQ(json["budget_unchecked"], (nlohmann::json{"end_to_end"}));
  fs::remove_all(dir);
}

// One table, two forms: the Markdown and the HTML carry the same cells,
// a flagged row loses its "!" in both, and Markdown aligns as asked.
TEST(HtmlReports, ATableIsWrittenOnceAsMarkdownAndAsHtml) {
  const html::Table t{{"scene", "PSNR", "verdict"},
                      {{"clean", "30.1 dB", "met"}, {"!busy", "<28 dB", "MISSED"}},
                      "lrl"};
  const std::string md = html::markdownTable(t);
  EXPECT_EQ(md,
            "| scene | PSNR | verdict |\n|---|---:|---|\n| clean | 30.1 dB | met |\n"
            "| busy | <28 dB | MISSED |\n");
  const std::string page = html::table(t);
  EXPECT_NE(page.find("<tr class=\"flagged\"><td>busy</td>"), std::string::npos) << page;
  EXPECT_NE(page.find("<td>&lt;28 dB</td>"), std::string::npos) << "HTML escapes, Markdown not";
  EXPECT_EQ(html::markdownTable({{"a", "b"}, {}, ""}), "| a | b |\n|---|---:|\n")
      << "by default the first column is text, the rest numbers";
}

TEST(LoopReport, JitterFollowsRfc3550) {
  // Constant transit: no jitter, whatever the send times.
  EXPECT_DOUBLE_EQ(interarrivalJitter({{0, 5}, {10, 15}, {25, 30}, {31, 36}}), 0.0);
  // Transit alternating 2 and 3 ms: |D| = 1 each step, J -> 1 as 1 - (15/16)^n.
  std::vector<std::pair<double, double>> alternating;
  for (int k = 0; k < 200; ++k) alternating.emplace_back(k * 100.0, k * 100.0 + 2 + k % 2);
  EXPECT_NEAR(interarrivalJitter(alternating), 1.0 - std::pow(15.0 / 16.0, 199), 1e-9);
  // The order of the list does not matter: packets are taken in order of
  // arrival. Sent at 0, 10, 20, the third overtakes the second: arrivals
  // 2 (transit 2), 23 (transit 3, sent 20), 24 (transit 14, sent 10).
  std::vector<std::pair<double, double>> shuffled = {{10, 24}, {0, 2}, {20, 23}};
  const double after_second = 1.0 / 16.0;
  EXPECT_NEAR(interarrivalJitter(shuffled), after_second + (11.0 - after_second) / 16.0, 1e-12);
  // A sender that comes back (another connection, maybe another clock):
  // its first transit is not a change from the last one's.
  ArrivalJitter jitter;
  jitter.add(0, 2);
  jitter.add(10, 13);
  jitter.restart();
  jitter.add(20, 5020);  // 5 s of clock offset
  EXPECT_NEAR(jitter.ms(), 1.0 / 16.0, 1e-12);
  EXPECT_EQ(jitter.packets(), 3u);
  jitter.add(30, 5031);
  EXPECT_NEAR(jitter.ms(), 1.0 / 16.0 + (1.0 - 1.0 / 16.0) / 16.0, 1e-12);
}

TEST(LoopReport, BudgetFilesAreCheckedAndNamed) {
  const fs::path dir = scratch("budget");
  std::ofstream(dir / "good.json") << R"({"hull": 40, "end_to_end": 300})";
  std::ofstream(dir / "unknown.json") << R"({"hul": 40})";
  std::ofstream(dir / "negative.json") << R"({"hull": -1})";
  std::ofstream(dir / "broken.json") << R"({"hull": )";
  auto good = protocol::loadBudget((dir / "good.json").string());
  ASSERT_TRUE(good.isOk());
  EXPECT_DOUBLE_EQ(good->at("end_to_end"), 300.0);
  const auto unknown = protocol::loadBudget((dir / "unknown.json").string());
  ASSERT_FALSE(unknown.isOk());
  EXPECT_NE(unknown.status().message().find("unknown stage 'hul'"), std::string::npos);
  EXPECT_NE(unknown.status().message().find("sync_wait"), std::string::npos)
      << "lists the valid names";
  EXPECT_FALSE(protocol::loadBudget((dir / "negative.json").string()).isOk());
  const auto broken = protocol::loadBudget((dir / "broken.json").string());
  ASSERT_FALSE(broken.isOk());
  EXPECT_NE(broken.status().message().find("broken.json"), std::string::npos);
  EXPECT_FALSE(protocol::loadBudget((dir / "missing.json").string()).isOk());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace holofuse
