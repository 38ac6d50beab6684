// The whole loop with real processes on loopback: pods, server and client
// started as executables, checked against the synthetic truth.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <regex>

#include "browser_check.h"
#include "loop_test.h"
#include "scene/synthetic_scene.h"

namespace {

using namespace holofuse::test;

TEST(Loop, FourPodsServerAndClientRenderTheSubjectWhereTheTruthIs) {
  const fs::path out = freshDir("loop");
  // At a rate the build sustains: sanitized, the pods render several times
  // slower and at 4 fps would miss the server's sync deadline every frame.
  const double fps = holofuse::test::kSanitized ? 1.0 : 4.0;
  // A budget no hull can meet and an end-to-end one no frame can miss: the
  // report flags the first and not the second, through the launcher's flag.
  std::ofstream(out / "budget.json") << R"({"hull": 0.001, "end_to_end": 100000})";
  ASSERT_EQ(runLoop(out, judgedFromPod0({"--pods", "4", "--frames", "6", "--fps",
                                         kSanitized ? "1" : "4", "--size", "200x150", "--budget",
                                         (out / "budget.json").string()})),
            0)
      << "see " << (out / "loop.log");
  const auto report = readJson(out / "report.json");
  ASSERT_EQ(report["frames_rendered"], 6);
  EXPECT_GT(report["fps"].get<double>(), 0.0);
  const auto& e2e = report["latency_ms"]["end_to_end"];
  EXPECT_GT(e2e["p50"].get<double>(), 0.0);
  EXPECT_LE(e2e["p50"].get<double>(), e2e["p95"].get<double>());
  EXPECT_LE(e2e["p95"].get<double>(), e2e["p99"].get<double>());
  for (const char* stage :
       {"pod_render", "segment", "feather", "pod_encode", "send", "server_decode", "sync_wait",
        "hull", "mesh_encode", "image_encode", "fanout", "decode", "upload", "render", "write"}) {
    ASSERT_TRUE(report["latency_ms"]["stages"].contains(stage)) << stage;
    EXPECT_GT(report["latency_ms"]["stages"][stage]["samples"].get<int>(), 0) << stage;
    EXPECT_LE(report["latency_ms"]["stages"][stage]["p50"].get<double>(), e2e["p99"].get<double>())
        << stage;
  }
  ASSERT_TRUE(report.contains("budget_violations")) << "the budget reached the client";
  ASSERT_EQ(report["budget_violations"].size(), 1u) << report["budget_violations"].dump();
  EXPECT_EQ(report["budget_violations"][0]["stage"], "hull");
  EXPECT_GT(report["budget_violations"][0]["p95"].get<double>(), 0.001);
  EXPECT_GT(report["bytes_per_frame"]["pod_link"].get<double>(), 1000.0);
  EXPECT_GT(report["bytes_per_frame"]["client_link"].get<double>(), 1000.0);

  // From pod 0's pose the rendered coverage must sit on the true silhouette
  // of the scene the pods render: seed 5, no sensor noise (the launcher
  // passes both to the pods and to the client's truth).
  holofuse::scene::SceneOptions scene_options;
  scene_options.frames_per_second = fps;
  scene_options.seed = 5;
  scene_options.noise_amplitude = 0;
  const holofuse::scene::SyntheticScene scene(scene_options);
  const auto camera = holofuse::scene::SyntheticScene::cameraRig(4, 200, 150)[0];
  // Frames the server had to fuse without a pod (a pod still starting, say)
  // carry fewer cameras; the truth check applies to complete ones, and most
  // frames must be complete.
  int checked = 0;
  for (const auto& frame : report["frames"]) {
    if (frame["cameras_present"] != 4) continue;
    const cv::Mat png =
        cv::imread((out / frame["file"].get<std::string>()).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(png.empty()) << frame["file"];
    ASSERT_EQ(png.channels(), 4);
    const auto truth = scene.render(camera, frame["frame_id"].get<uint64_t>());
    size_t inter = 0, uni = 0;
    double squared = 0;
    size_t values = 0;
    for (int y = 0; y < png.rows; ++y) {
      for (int x = 0; x < png.cols; ++x) {
        const bool rendered = png.at<cv::Vec4b>(y, x)[3] != 0;
        const bool real = *truth.mask.at(x, y) != 0;
        inter += rendered && real;
        uni += rendered || real;
        for (int c = 0; c < 3 && real; ++c, ++values) {
          const double d =
              double(png.at<cv::Vec4b>(y, x)[2 - c]) - double(truth.color.at(x, y)[c]);  // BGRA
          squared += d * d;
        }
      }
    }
    // The judge the launcher's --quality gives the client (holofuse_judge)
    // judged the frame against the same truth: its PSNR is the one
    // recomputed here from the PNG, and from pod 0's own pose, its image in
    // the blend, it is high.
    const double psnr = 10 * std::log10(255.0 * 255.0 * static_cast<double>(values) / squared);
    ASSERT_TRUE(frame["psnr_db"].is_number()) << frame.dump();
    EXPECT_NEAR(frame["psnr_db"].get<double>(), psnr, 1e-6) << frame["file"];
    EXPECT_GT(psnr, 20.0) << frame["file"];
    EXPECT_GT(frame["ssim"].get<double>(), 0.8) << frame["file"];
    // The visual hull is a superset of the subject, so the overlap is high
    // but not perfect.
    EXPECT_GT(static_cast<double>(inter) / static_cast<double>(uni), 0.8) << frame["file"];
    ++checked;
  }
  EXPECT_GE(checked, 4);
  EXPECT_EQ(report["quality"]["psnr_db"]["frames"], 6) << "every written frame judged";
  EXPECT_LE(report["quality"]["psnr_db"]["worst"].get<double>(),
            report["quality"]["psnr_db"]["mean"].get<double>());

  // The page the run wrote, in a browser: the latency stack, the slowest
  // frames split by stage, bytes per link and the server's jitter per pod
  // drawn as their values say, the hull flagged over budget, the quality
  // table.
  if (holofuse::test::chromium().empty())
    GTEST_SKIP() << "chromium is not installed (./holofuse deps installs it)";
  EXPECT_EQ(holofuse::test::chartsRendered(out / "report.html"), 4);
  const std::string page = readFile(out / "report.html");
  EXPECT_NE(page.find("The slowest frames: where their time went"), std::string::npos);
  EXPECT_NE(page.find("Arrival jitter per pod (at the server, every frame)"), std::string::npos);
  EXPECT_NE(page.find("<tr class=\"flagged\"><td>hull</td>"), std::string::npos);
  EXPECT_NE(page.find("<h2>Quality against the truth</h2>"), std::string::npos);
}

// Mode layered through the live loop (protocol 1.6): the client asks for
// texture layers, the server builds them in a stage of their own, codes
// their colour as H.264 in another and sends them in place of the images,
// the client decodes the streams (a key frame when it joined, then
// predicted frames), and its pictures from pod 0's pose are judged against
// the truth as mode normal's are, and records each layer's stream as a
// video file. (LZ4 layers: LeaveOneOut.ModeLayered...)
// The meshes come as half floats through LZ4 (protocol 1.7), so the layers
// are laid out on the mesh as that codec gives it back.
TEST(Loop, ModeLayeredRendersFromTheServersTextureLayers) {
  const fs::path out = freshDir("loop_layered");
  ASSERT_EQ(
      runLoop(out, judgedFromPod0({"--pods", "4", "--frames", "4", "--fps", kSanitized ? "1" : "2",
                                   "--size", "200x150", "--mode", "layered", "--layer-video",
                                   "h264", "--mesh-codec", "fp16-lz4", "--record-layers",
                                   (out / "layers").string()})),
      0)
      << "see " << (out / "loop.log");
  // --record-layers: each layer's stream as received, files ffprobe reads
  // frame by frame (every frame received, superseded ones too). A new
  // atlas size (the surface outgrew the grid) starts a new part.
  if (::access("/usr/bin/ffprobe", X_OK) == 0) {
    int frames = 0;
    for (int part = 0; fs::exists(out / "layers" / ("layer0_part" + std::to_string(part) + ".ts"));
         ++part) {
      const fs::path probed = out / ("layer0_part" + std::to_string(part) + ".json");
      ASSERT_EQ(
          waitExit(
              spawn({"/usr/bin/ffprobe", "-v", "error", "-count_frames", "-show_entries",
                     "stream=codec_name,nb_read_frames", "-of", "json",
                     (out / "layers" / ("layer0_part" + std::to_string(part) + ".ts")).string()},
                    probed),
              60),
          0)
          << readFile(probed);
      const auto stream = nlohmann::json::parse(readFile(probed))["streams"].at(0);
      EXPECT_EQ(stream["codec_name"], "h264") << stream.dump();
      frames += std::stoi(stream["nb_read_frames"].get<std::string>());
    }
    EXPECT_GE(frames, 4) << "layer 0's parts hold every frame received";
  }
  const auto report = readJson(out / "report.json");
  ASSERT_EQ(report["frames_rendered"], 4);
  const auto& stages = report["latency_ms"]["stages"];
  EXPECT_EQ(stages["layers"]["samples"].get<int>(), 4) << "one layer build per frame";
  EXPECT_EQ(stages["image_encode"]["samples"].get<int>(), 0) << "no camera images sent";
  EXPECT_GT(stages["layers"]["p50"].get<double>(), 0.0);
  EXPECT_EQ(stages["layer_video"]["samples"].get<int>(), 4) << "the layers coded as video";
  const std::string server_log = readFile(out / "logs" / "server.log");
  EXPECT_NE(server_log.find("texture layers as video"), std::string::npos) << server_log;
  EXPECT_NE(server_log.find("meshes fp16-lz4"), std::string::npos) << server_log;
  int judged = 0;
  for (const auto& frame : report["frames"]) {
    if (frame["cameras_present"] != 4) continue;
    // Resampled into the atlas, coded and back, pod 0's own view stays
    // close to the truth (measured: PSNR 23.4-25.6 dB, SSIM 0.91-0.95; LZ4
    // layers 24.4-25.3 dB, SSIM 0.94-0.95).
    EXPECT_GT(frame["psnr_db"].get<double>(), 20.0) << frame.dump();
    EXPECT_GT(frame["ssim"].get<double>(), 0.8) << frame.dump();
    ++judged;
  }
  EXPECT_GE(judged, 2);
}

// A rig past the 16 cameras the loop once held and past the 32 of one bit
// word: every pod is heard, every frame fuses all 32, and the blend of
// each vertex's best views shows the subject.
TEST(Loop, ThirtyTwoPodsAreAllFusedAndBlended) {
  const fs::path out = freshDir("loop32");
  ASSERT_EQ(runLoop(out, judgedFromPod0({"--pods", "32", "--frames", "3", "--fps", "2", "--size",
                                         "96x72", "--mode", "montage4d"})),
            0)
      << "see " << (out / "loop.log");
  const auto report = readJson(out / "report.json");
  ASSERT_EQ(report["frames_rendered"], 3);
  ASSERT_EQ(report["pod_frames_at_server"].size(), 32u) << report["pod_frames_at_server"].dump();
  for (int pod = 0; pod < 32; ++pod) {
    EXPECT_GT(report["pod_frames_at_server"]["pod_" + std::to_string(pod)].get<int>(), 0) << pod;
  }
  int complete = 0;
  for (const auto& frame : report["frames"]) {
    complete += frame["cameras_present"] == 32;
    // Measured 16.6-17.4 dB, SSIM 0.68-0.69 from pod 0's pose at 96x72
    // (the blend of its 8 best views on a hull of 32 coarse silhouettes).
    EXPECT_GT(frame["psnr_db"].get<double>(), 13.0) << frame.dump();
    EXPECT_GT(frame["ssim"].get<double>(), 0.5) << frame.dump();
  }
  EXPECT_GE(complete, 1) << report["frames"].dump();
}

// The server's pipeline shows in the report: with pods faster than the
// fusion worker (a 10 mm hull takes it hundreds of ms a frame, the pods
// send every 33 ms), the frames' pod images are decoded while the worker
// still carves or encodes the frame before (measured: 1 to 3 of 7 pairs,
// hence 15 pairs here; a pair is split by each frame the server dropped
// or the client superseded between them); with pods far slower than the
// worker (0.5 fps, a 30 mm hull), at most once: only a pod that a loaded
// machine stalled for most of a period sends its frame so late that the
// next one comes while it fuses (seen once in CI, 1 pair of 7 at 1 fps,
// by 32 ms).
//
// Fused on two threads, the busy server also carves a group while it
// encodes the one before; on one thread that can never happen. The server
// counts it over every group it fuses, since a client sees only the frames
// it took: one that renders slower than the server fuses takes every other
// group, and two groups apart never overlap (that made a count from the
// client's report a matter of luck: measured 0 to 6 of 15 pairs, 0 on an
// idle machine). With the pods sending every 33 ms and a group taking
// hundreds of ms, a group always waits for the second thread.
TEST(Loop, TheReportShowsTheServerDecodingTheNextFrameWhileItFusesThisOne) {
  const fs::path out = freshDir("loop_pipeline");
  auto run = [&](const std::string& name, const std::string& fps, const std::string& voxel,
                 const std::string& frames, const std::string& threads) {
    const pid_t loop = spawn({kBin + "/holofuse_loop", "--pods", "2", "--frames", frames, "--fps",
                              fps, "--size", "96x72", "--voxel", voxel, "--fusion-threads", threads,
                              "--frames-ahead", "0", "--out", (out / name).string()},
                             out / (name + ".log"));
    EXPECT_EQ(waitExit(loop, 240), 0) << readFile(out / (name + ".log"));
    return readJson(out / name / "report.json")["server_pipeline"];
  };
  // "N of M begun before the one before was done, on T fusion thread(s)"
  auto fusedAtOnce = [&](const std::string& name) {
    const std::string log = readFile(out / name / "logs" / "server.log");
    std::smatch match;
    static const std::regex said(
        R"((\d+) of (\d+) begun before the one before was done, on (\d+) fusion threads?)");
    EXPECT_TRUE(std::regex_search(log, match, said)) << log;
    struct Count {
      int at_once = -1, pairs = -1, threads = -1;
    };
    if (match.empty()) return Count{};
    return Count{std::stoi(match[1]), std::stoi(match[2]), std::stoi(match[3])};
  };
  const auto busy = run("busy", "30", "0.01", "16", "2");
  ASSERT_EQ(busy["frame_pairs"].get<int>(), 15) << busy.dump();
  EXPECT_GE(busy["overlapped"].get<int>(), 1) << busy.dump();
  EXPECT_GT(busy["overlap_ms"]["p95"].get<double>(), 0.0) << busy.dump();
  ASSERT_EQ(busy["fusion_frame_pairs"].get<int>(), 15) << busy.dump();
  const auto busy_server = fusedAtOnce("busy");
  EXPECT_EQ(busy_server.threads, 2);
  EXPECT_GE(busy_server.pairs, 15);
  // Every pair but those around a pause of the pods (none expected).
  EXPECT_GE(busy_server.at_once, busy_server.pairs / 2)
      << busy_server.at_once << " of " << busy_server.pairs;
  const auto one_thread = run("one_thread", "30", "0.01", "16", "1");
  ASSERT_EQ(one_thread["fusion_frame_pairs"].get<int>(), 15) << one_thread.dump();
  EXPECT_EQ(one_thread["fusion_overlapped"].get<int>(), 0) << one_thread.dump();
  const auto one_thread_server = fusedAtOnce("one_thread");
  EXPECT_EQ(one_thread_server.threads, 1);
  EXPECT_GE(one_thread_server.pairs, 15);
  EXPECT_EQ(one_thread_server.at_once, 0);
  const auto idle = run("idle", "0.5", "0.03", "8", "0");
  ASSERT_EQ(idle["frame_pairs"].get<int>(), 7) << idle.dump();
  EXPECT_LE(idle["overlapped"].get<int>(), 1) << idle.dump();
  fs::remove_all(out);
}

// --hull-device vulkan: the server carves its hull on the device (here
// lavapipe) and says so, and the pictures are judged as good as the
// CPU hull's (measured 16-17 dB from pod 0's pose at 96x72, as the CPU's);
// a server whose device does not open carves on the CPU, says why in one
// line, and still fuses every frame.
TEST(Loop, TheHullCarvedOnTheDeviceOrOnTheCpuWhereNoDeviceOpens) {
  const fs::path out = freshDir("loop_hull_device");
  fs::create_directories(out / "vulkan");
  ASSERT_EQ(runLoop(out / "vulkan", judgedFromPod0({"--pods", "2", "--frames", "4", "--fps", "4",
                                                    "--size", "96x72", "--hull-device", "vulkan"})),
            0)
      << readFile(out / "vulkan" / "loop.log");
  EXPECT_TRUE(logSays(out / "vulkan" / "logs" / "server.log", "[server] hull carved on llvmpipe"))
      << readFile(out / "vulkan" / "logs" / "server.log");
  const auto report = readJson(out / "vulkan" / "report.json");
  ASSERT_EQ(report["frames_rendered"].get<int>(), 4);
  EXPECT_GT(report["mesh_triangles"]["p50"].get<double>(), 100.0);
  for (const auto& frame : report["frames"]) {
    if (frame["cameras_present"] != 2) continue;
    EXPECT_GT(frame["psnr_db"].get<double>(), 12.0) << frame.dump();
  }

  pid_t server = 0;
  const std::string endpoint =
      startServer(out, 2, &server, {"--hull-device", "vulkan"},
                  {"/usr/bin/env", "VK_ICD_FILENAMES=" + (out / "no_such_icd.json").string()});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  EXPECT_TRUE(
      logSays(out / "server.log", "[server] hull carved on the CPU: no Vulkan device opened ("))
      << readFile(out / "server.log");
  const pid_t pods[] = {startSmallPod(endpoint, 0, 2, out), startSmallPod(endpoint, 1, 2, out)};
  const pid_t client = startSmallClient(endpoint, out, "client", 3);
  EXPECT_EQ(waitExit(client, 240), 0) << readFile(out / "client.log");
  EXPECT_EQ(picturesIn(out / "client"), 3u);
  for (pid_t pod : pods) kill(pod, SIGTERM);
  kill(server, SIGTERM);
  for (pid_t pod : pods) waitExit(pod, 60);
  EXPECT_EQ(waitExit(server, 60), 0) << readFile(out / "server.log");
  fs::remove_all(out);
}

// --overlap-render on: the client receives and decodes the next frames
// while the device renders (lavapipe's queue thread). It still renders
// exactly the frames asked for, each written and stamped; auto keeps a CPU
// device's renders waited for, and the client says which it does.
TEST(Loop, AClientDecodingWhileItRendersRendersEveryFrameAskedFor) {
  const fs::path out = freshDir("loop_overlap");
  auto run = [&](const std::string& overlap) {
    const pid_t loop = spawn(
        {kBin + "/holofuse_loop", "--pods", "2", "--frames", "8", "--fps", "30", "--size", "96x72",
         "--mode", "montage4d", "--overlap-render", overlap, "--out", (out / overlap).string()},
        out / (overlap + ".log"));
    EXPECT_EQ(waitExit(loop, 240), 0) << readFile(out / (overlap + ".log"));
    return readJson(out / overlap / "report.json");
  };
  const auto on = run("on");
  EXPECT_EQ(on["frames_rendered"].get<int>(), 8);
  EXPECT_EQ(on["frames"].size(), 8u);
  for (const auto& frame : on["frames"]) {
    EXPECT_TRUE(fs::exists(out / "on" / frame["file"].get<std::string>())) << frame.dump();
    EXPECT_GT(frame["end_to_end_ms"].get<double>(), 0.0) << frame.dump();
  }
  for (const char* stage : {"decode", "upload", "render"}) {
    EXPECT_GT(on["latency_ms"]["stages"][stage]["p50"].get<double>(), 0.0) << stage;
  }
  EXPECT_NE(readFile(out / "on" / "logs" / "client.log").find("decoded while this one renders"),
            std::string::npos);
  run("auto");
  const std::string automatic = readFile(out / "auto" / "logs" / "client.log");
  const bool cpu_device = automatic.find("llvmpipe") != std::string::npos;
  EXPECT_NE(automatic.find(cpu_device ? "decoded after this one renders"
                                      : "decoded while this one renders"),
            std::string::npos)
      << automatic;
  fs::remove_all(out);
}

// The sweep's knobs (holofuse_sweep) are flags of the loop too, so a point
// can be run live: each reaches the process it belongs to, which says so in
// its report or its log.
TEST(Loop, SweepSettingsReachTheProcessesTheyBelongTo) {
  const fs::path out = freshDir("loop_settings");
  ASSERT_EQ(runLoop(out,
                    {"--pods",
                     "2",
                     "--frames",
                     "2",
                     "--fps",
                     "4",
                     "--size",
                     "160x120",
                     "--mode",
                     "montage4d",
                     "--voxel",
                     "0.03",
                     "--draco-bits",
                     "12",
                     "--image-codec",
                     "lz4",
                     "--lz4-acceleration",
                     "8",
                     "--crop-margin",
                     "3",
                     "--lz4-hc-level",
                     "4",
                     "--alpha",
                     "3",
                     "--lambda",
                     "0.5",
                     "--beta",
                     "7",
                     "--feather-width",
                     "4",
                     "--fragment-test",
                     "on",
                     "--dilation",
                     "1",
                     "--vote-delta",
                     "0.25",
                     "--geodesic-rings",
                     "9",
                     "--geodesic-passes",
                     "11",
                     "--geodesic-radius",
                     "0.04",
                     "--vertex-precision",
                     "fp16"},
                    120),
            0)
      << readFile(out / "loop.log");
  const auto settings = readJson(out / "report.json").at("settings");
  const std::map<std::string, std::string> expected = {{"mode", "montage4d"},
                                                       {"alpha", "3"},
                                                       {"lambda", "0.5"},
                                                       {"dilation", "1"},
                                                       {"vote_delta", "0.25"},
                                                       {"geodesic_rings", "9"},
                                                       {"geodesic_passes", "11"},
                                                       {"geodesic_radius", "0.04"},
                                                       {"vertex_precision", "fp16"},
                                                       {"beta", "7"},
                                                       {"feather_width", "4"},
                                                       {"fragment_test", "on"}};
  for (const auto& [key, value] : expected)
    EXPECT_EQ(settings.at(key).get<std::string>(), value) << key;
  const std::string server_log = readFile(out / "logs" / "server.log");
  EXPECT_NE(server_log.find("voxel 0.03 m"), std::string::npos) << server_log;
  EXPECT_NE(server_log.find("Draco 12 bits"), std::string::npos) << server_log;
  EXPECT_NE(server_log.find("images to clients lz4 at LZ4 acceleration 8, LZ4HC level 4"),
            std::string::npos)
      << server_log;
  for (int pod = 0; pod < 2; ++pod) {
    const std::string pod_log = readFile(out / "logs" / ("pod" + std::to_string(pod) + ".log"));
    EXPECT_NE(pod_log.find("colour lz4 at LZ4 acceleration 8, crop margin 3, LZ4HC level 4"),
              std::string::npos)
        << pod_log;
  }
  // A value outside the range of the process it goes to is refused before
  // anything starts, naming the flag.
  const fs::path refused = freshDir("loop_settings_refused");
  EXPECT_EQ(
      waitExit(spawn({kBin + "/holofuse_loop", "--geodesic-rings", "65", "--out", refused.string()},
                     refused / "loop.log"),
               10),
      2);
  EXPECT_NE(readFile(refused / "loop.log").find("--geodesic-rings"), std::string::npos);
  EXPECT_FALSE(fs::exists(refused / "logs"));
  // Every forwarded flag is checked by the launcher (with the range of the
  // process it goes to: its flag table, config/settings.h), not left to fail later; so
  // are the client's mode, view, size and budget file.
  for (const char* flag :
       {"--voxel", "--draco-bits", "--image-codec", "--lz4-acceleration", "--alpha", "--lambda",
        "--dilation", "--vote-delta", "--geodesic-rings", "--geodesic-passes", "--geodesic-radius",
        "--vertex-precision", "--crop-margin", "--lz4-hc-level", "--mode", "--view", "--size",
        "--budget"}) {
    const fs::path log = refused / "nonsense.log";
    EXPECT_EQ(
        waitExit(spawn({kBin + "/holofuse_loop", flag, "nonsense", "--out", refused.string()}, log),
                 10),
        2)
        << flag;
    EXPECT_NE(readFile(log).find(flag), std::string::npos) << readFile(log);
  }
  EXPECT_FALSE(fs::exists(refused / "logs"));
  // A replay has no truth to judge frames by.
  const fs::path judged = refused / "quality.log";
  EXPECT_EQ(waitExit(spawn({kBin + "/holofuse_loop", "--replay", refused.string(), "--quality",
                            "--out", refused.string()},
                           judged),
                     10),
            2);
  EXPECT_NE(readFile(judged).find("--quality needs a synthetic scene"), std::string::npos)
      << readFile(judged);
}

TEST(Loop, WrongFlagsPrintUsageAndFail) {
  const fs::path out = freshDir("flags");
  EXPECT_EQ(waitExit(spawn({kBin + "/capture_node", "--server", "127.0.0.1:1", "--pod-id", "9",
                            "--pods", "4"},
                           out / "a.log"),
                     10),
            2);
  EXPECT_EQ(waitExit(spawn({kBin + "/fusion_server", "--no-such-flag"}, out / "b.log"), 10), 2);
  EXPECT_EQ(waitExit(spawn({kBin + "/render_client", "--server", "nonsense"}, out / "c.log"), 10),
            2);
  // A replay pod sends recorded bytes: a synthetic pod's flag is refused.
  EXPECT_EQ(waitExit(spawn({kBin + "/capture_node", "--server", "127.0.0.1:1", "--pod-id", "0",
                            "--replay", "x", "--codec", "lz4"},
                           out / "e.log"),
                     10),
            2);
  EXPECT_NE(readFile(out / "e.log").find("--codec"), std::string::npos);
  // A value out of range (CLI11's checks) exits 2 as well, naming the flag.
  EXPECT_EQ(waitExit(spawn({kBin + "/render_client", "--server", "127.0.0.1:1", "--alpha", "-1"},
                           out / "d.log"),
                     10),
            2);
  EXPECT_NE(readFile(out / "d.log").find("--alpha"), std::string::npos);
  std::ifstream log(out / "a.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("--pod-id"), std::string::npos);
  // A typo is answered with the flag it is nearest to; a word near none
  // with nothing but the error.
  EXPECT_EQ(waitExit(spawn({kBin + "/holofuse_loop", "--frame", "5"}, out / "f.log"), 10), 2);
  EXPECT_NE(readFile(out / "f.log").find("--frame: did you mean --frames?"), std::string::npos)
      << readFile(out / "f.log");
  EXPECT_EQ(
      waitExit(spawn({kBin + "/render_client", "--server", "127.0.0.1:1", "--mdoe", "montage4d"},
                     out / "g.log"),
               10),
      2);
  EXPECT_NE(readFile(out / "g.log").find("--mdoe: did you mean --mode?"), std::string::npos)
      << readFile(out / "g.log");
  EXPECT_EQ(waitExit(spawn({kBin + "/fusion_server", "--no-such-flag"}, out / "b.log"), 10), 2);
  EXPECT_EQ(readFile(out / "b.log").find("did you mean"), std::string::npos)
      << readFile(out / "b.log");
}

// A client pointed at a server that never answers (nothing listens on
// port 1) gives up after --give-up-after, saying where it tried; without
// the flag it keeps trying (the launcher's clients, started before their
// server listens).
TEST(Loop, AClientGivesUpOnAServerThatNeverAnswers) {
  const fs::path out = freshDir("give_up");
  EXPECT_EQ(waitExit(spawn({kBin + "/render_client", "--server", "127.0.0.1:1", "--out",
                            (out / "client").string(), "--give-up-after", "1"},
                           out / "client.log"),
                     60),
            1);
  const std::string log = readFile(out / "client.log");
  EXPECT_NE(log.find("[client] giving up: no server answered at 127.0.0.1:1 for 1 s "
                     "(--give-up-after)"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("cannot reach server 127.0.0.1:1"), std::string::npos) << log;
  fs::remove_all(out);
}

}  // namespace
