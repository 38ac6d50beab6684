// bench_scaling: what one server core, one client device and each link
// carry, from the stages the live loop measures (docs/scaling.md). For each
// point of a grid (pods, image size, voxel, mode) it runs the real loop
// (holofuse_loop) at a low frame rate, so that a stage rarely waits for the
// machine's two cores, reads the client's report, and derives:
//   - the server's CPU ms per fused frame: every pod image's decode, the
//     hull, the mesh encode and the images' encode for clients (the
//     stages a server core runs; sync_wait and fan-out are waiting);
//   - a pod's ms per frame (render, segment, feather, encode: its own PC);
//   - the client's ms per frame (decode, upload, render);
//   - the bytes per frame on a pod's link and a client's link, and their
//     Mbit/s at 15 and 30 fps;
//   - the frames per second each of them carries (and the fusion alone:
//     the hull and the encodes), and which is the first to stop a rig at
//     30 fps (a 1 Gbit/s link counted as one).
// The loop's server fuses on one thread (--fusion-threads 1), so that its
// stages are one core's cost. Then the server's fusion on 1 thread and on
// more (--fusion-threads), in
// this process on the same groups of the synthetic scene, fed as fast as
// it takes them: the ms per fused frame each thread count sustains.
//   bench_scaling [--frames F] [--fps R] [--quick] [--out DIR] [--markdown FILE]
#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "base/process.h"
#include "capture_node/pod.h"
#include "config/command_line.h"
#include "config/rig_shape.h"
#include "fusion_server/fusion_worker.h"
#include "loop_run.h"
#include "report/html.h"
#include "scene/synthetic_scene.h"

namespace fs = std::filesystem;
using nlohmann::ordered_json;
using namespace holofuse;

namespace {

constexpr double kTargetFps = 30;
constexpr double kLinkMbit = 1000;  // a rig's links: gigabit Ethernet

struct Point {
  int pods;
  std::string size, voxel_mm, mode;
};

struct Costs {
  double server_ms = 0, pod_ms = 0, client_ms = 0;
  double decode_ms = 0, hull_ms = 0, mesh_encode_ms = 0, image_encode_ms = 0;
  double triangles = 0, pod_link_bytes = 0, client_link_bytes = 0, mesh_bytes = 0;
};

double stageP50(const ordered_json& report, const char* stage) {
  const auto& stages = report["latency_ms"]["stages"];
  if (!stages.contains(stage) || stages[stage].value("samples", 0) == 0) return 0;
  return stages[stage]["p50"].get<double>();
}

Costs costsOf(const ordered_json& report, int pods) {
  Costs c;
  c.decode_ms = stageP50(report, "server_decode") * pods;  // one sample per pod image
  c.hull_ms = stageP50(report, "hull");
  c.mesh_encode_ms = stageP50(report, "mesh_encode");
  c.image_encode_ms = stageP50(report, "image_encode");
  c.server_ms = c.decode_ms + c.hull_ms + c.mesh_encode_ms + c.image_encode_ms;
  for (const char* stage : {"pod_render", "segment", "feather", "pod_encode"})
    c.pod_ms += stageP50(report, stage);
  for (const char* stage : {"decode", "upload", "render"}) c.client_ms += stageP50(report, stage);
  c.triangles = report["mesh_triangles"]["p50"].get<double>();
  const auto& bytes = report["bytes_per_frame"];
  c.pod_link_bytes = bytes["pod_link"].get<double>() / pods;
  c.client_link_bytes = bytes["client_link"].get<double>();
  c.mesh_bytes = bytes.value("client_link_mesh", 0.0);
  return c;
}

std::string fixed(double v, const char* format = "%.1f") {
  char text[32];
  std::snprintf(text, sizeof text, format, v);
  return text;
}

double mbit(double bytes_per_frame, double fps) { return bytes_per_frame * 8 * fps / 1e6; }

// `frames` groups of the synthetic scene's subject through the pods' own
// capture (render, segmentation, feather map), as the server fuses them.
std::vector<fusion::GroupJob> syntheticGroups(int pods, uint32_t width, uint32_t height,
                                              int frames) {
  const scene::SyntheticScene scene;
  const auto cameras = scene::SyntheticScene::cameraRig(pods, width, height);
  std::vector<fusion::GroupJob> jobs;
  for (int f = 0; f < frames; ++f) {
    fusion::GroupJob job;
    job.group.frame_id = 30 + static_cast<uint64_t>(f);
    job.group.complete = true;
    for (const auto& camera : cameras) {
      capture::PodCapture capture =
          capture::capturePodFrame(scene, camera, scene.backgroundPlate(camera), job.group.frame_id,
                                   static_cast<uint16_t>(camera.id));
      fusion::PodImages pod;
      pod.camera_id = camera.id;
      pod.color = std::move(capture.view.color);
      pod.mask = std::move(capture.mask);
      pod.feather = std::move(capture.feather);
      pod.camera = camera;
      job.group.pods[camera.id] = std::move(pod);
    }
    jobs.push_back(std::move(job));
  }
  return jobs;
}

// The ms per frame a fusion worker of `threads` threads sustains on jobs
// handed to it all at once (lossless: none replaced), first submit to
// last output.
double fusionMsPerFrame(const std::vector<fusion::GroupJob>& jobs, double voxel, int threads) {
  fusion::FusionSettings settings;
  settings.hull.voxel_size = voxel;
  settings.pods_expected = static_cast<uint32_t>(jobs.front().group.pods.size());
  settings.threads = threads;
  const int wake = ::eventfd(0, 0);
  size_t fused = 0;
  double ms = 0;
  {
    fusion::FusionWorker worker(settings, wake, /*lossless=*/true);
    // Copied before the clock starts: a server's groups are decoded into
    // place and moved in, never copied, and the copies of eight 640x480
    // pods' images would otherwise take a core from the threads measured.
    std::vector<fusion::GroupJob> handed = jobs;
    const auto start = std::chrono::steady_clock::now();
    for (auto& job : handed) worker.submit(std::move(job));
    while (fused < jobs.size()) {
      // A group that failed to fuse never wakes us: a limit, not a pace.
      pollfd woken{wake, POLLIN, 0};
      if (::poll(&woken, 1, 120'000) <= 0) break;
      uint64_t counter = 0;
      if (::read(wake, &counter, sizeof counter) < 0) break;
      fused += worker.takeOutputs().size();
    }
    ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  ::close(wake);
  return fused == jobs.size() ? ms / static_cast<double>(jobs.size()) : 0;
}

// The fusion's ms per frame on 1 thread and on 2 (and on every core where
// there are more), each the best of five rounds taken in turn: the
// machine is shared, and the least disturbed round is each count's own
// cost (the medians of three swung from 0.52 to 0.65 at one point).
html::Table fusionThreadsTable(bool quick) {
  // The server's own allocator settings (fusion_server's main holds one):
  // without them glibc maps each 640x480 image on its own and unmaps it
  // when freed, and two threads fusing 8 such pods serialised on the
  // address space's lock (2 / 1 measured 1.04 without them, 0.6 with).
  const FreeMemoryReturner free_memory;
  const int cores = static_cast<int>(std::max(2u, std::thread::hardware_concurrency()));
  std::vector<int> counts = {1, 2};
  if (cores > 2) counts.push_back(cores);
  struct FusionPoint {
    int pods;
    uint32_t width, height;
    double voxel_mm;
  };
  const std::vector<FusionPoint> points =
      quick ? std::vector<FusionPoint>{{2, 96, 72, 20}}
            : std::vector<FusionPoint>{
                  {4, 320, 240, 20}, {8, 320, 240, 20}, {8, 640, 480, 20}, {4, 320, 240, 10}};
  std::vector<std::string> header = {"pods", "size", "voxel mm"};
  for (int n : counts) header.push_back(std::to_string(n) + (n == 1 ? " thread" : " threads"));
  for (size_t k = 1; k < counts.size(); ++k) header.push_back(std::to_string(counts[k]) + " / 1");
  html::Table table{header, {}, std::string(header.size(), 'r')};
  for (size_t i = 0; i < points.size(); ++i) {
    const FusionPoint& p = points[i];
    std::fprintf(stderr, "\r[bench scaling] fusion threads %zu/%zu: %d pods at %ux%u, %g mm   ",
                 i + 1, points.size(), p.pods, p.width, p.height, p.voxel_mm);
    const auto jobs = syntheticGroups(p.pods, p.width, p.height, quick ? 4 : 16);
    std::vector<double> ms(counts.size(), 0);
    for (int round = 0; round < (quick ? 2 : 5); ++round) {
      for (size_t k = 0; k < counts.size(); ++k) {
        const double round_ms = fusionMsPerFrame(jobs, p.voxel_mm / 1000, counts[k]);
        if (round_ms > 0 && (ms[k] == 0 || round_ms < ms[k])) ms[k] = round_ms;  // 0: lost frames
      }
    }
    std::vector<std::string> row = {std::to_string(p.pods),
                                    std::to_string(p.width) + "x" + std::to_string(p.height),
                                    fixed(p.voxel_mm, "%g")};
    for (double v : ms) row.push_back(fixed(v));
    for (size_t k = 1; k < ms.size(); ++k) row.push_back(fixed(ms[k] / ms[0], "%.2f"));
    table.rows.push_back(std::move(row));
  }
  std::fprintf(stderr, "\n");
  return table;
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 12;
  double fps = 2;
  bool quick = false;
  std::string out = "out/bench-scaling", markdown;
  CLI::App app{"bench_scaling: what a server core, a client device and a link carry"};
  app.add_option("--frames", frames, "frames each point's loop renders")
      ->check(CLI::Range(4, 10000));
  // The pods' --fps, from their table: low by default, so that stages
  // measure their cost, not the queue.
  const SettingFlags<RigShape> shape_flags(app, pickSettings(rigShapeFlags(), {"--fps"}));
  app.add_flag("--quick", quick, "two small points (for the tests)");
  bool fusion_only = false;
  app.add_flag("--fusion-only", fusion_only,
               "only the fusion's table of thread counts (no loop runs)");
  app.add_option("--out", out, "where each point's run goes");
  app.add_option("--markdown", markdown, "also write the tables to this file");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  RigShape shape;
  shape.fps = fps;
  shape_flags.apply(shape);
  fps = shape.fps;
  if (fusion_only) {
    std::printf("%s", html::markdownTable(fusionThreadsTable(quick)).c_str());
    return 0;
  }
  std::vector<Point> points;
  if (quick) {
    points = {{2, "96x72", "20", "normal"}, {4, "96x72", "20", "normal"}};
  } else {
    points = {{2, "320x240", "20", "normal"},   {4, "320x240", "20", "normal"},
              {8, "320x240", "20", "normal"},   {4, "160x120", "20", "normal"},
              {4, "640x480", "20", "normal"},   {8, "640x480", "20", "normal"},
              {4, "320x240", "10", "normal"},   {4, "320x240", "20", "montage4d"},
              {8, "320x240", "20", "montage4d"}};
  }
  std::vector<Costs> costs;
  for (size_t i = 0; i < points.size(); ++i) {
    const Point& p = points[i];
    std::fprintf(stderr, "\r[bench scaling] %zu/%zu: %d pods at %s, %s mm voxel, %s   ", i + 1,
                 points.size(), p.pods, p.size.c_str(), p.voxel_mm.c_str(), p.mode.c_str());
    const fs::path dir = fs::path(out) / ("point-" + std::to_string(i + 1));
    std::string error;
    const auto report = bench::runLoop(
        {"--pods", std::to_string(p.pods), "--size", p.size, "--voxel",
         fixed(std::stod(p.voxel_mm) / 1000, "%g"), "--mode", p.mode, "--fps", fixed(fps, "%g"),
         "--frames", std::to_string(frames), "--fusion-threads", "1"},
        dir, &error);
    if (!report) {
      std::fprintf(stderr, "\n[bench scaling] point %zu failed: %s\n", i + 1, error.c_str());
      return 1;
    }
    costs.push_back(costsOf(*report, p.pods));
  }
  std::fprintf(stderr, "\n");

  html::Table cost_table{
      {"pods", "size", "voxel mm", "mode", "triangles", "server ms/frame", "of it decode", "hull",
       "mesh enc", "image enc", "pod ms/frame", "client ms/frame"},
      {},
      "rrrlrrrrrrrr"};
  html::Table carry_table{
      {"pods", "size", "voxel mm", "mode", "server core fps", "cores for 30 fps", "fusion fps",
       "pod fps", "client fps", "pod link Mbit/s @15/30", "client link Mbit/s @15/30", "mesh share",
       "first bottleneck"},
      {},
      "rrrlrrrrrrrrl"};
  for (size_t i = 0; i < points.size(); ++i) {
    const Point& p = points[i];
    const Costs& c = costs[i];
    cost_table.rows.push_back({std::to_string(p.pods), p.size, p.voxel_mm, p.mode,
                               fixed(c.triangles, "%.0f"), fixed(c.server_ms), fixed(c.decode_ms),
                               fixed(c.hull_ms), fixed(c.mesh_encode_ms), fixed(c.image_encode_ms),
                               fixed(c.pod_ms), fixed(c.client_ms)});
    // What each carries alone, in frames per second; the server's link
    // in carries every pod's frames.
    const std::vector<std::pair<std::string, double>> limits = {
        {"server core", 1000 / std::max(c.server_ms, 1e-3)},
        {"pod", 1000 / std::max(c.pod_ms, 1e-3)},
        {"client", 1000 / std::max(c.client_ms, 1e-3)},
        {"server's link in", kLinkMbit / std::max(mbit(c.pod_link_bytes * p.pods, 1), 1e-9)},
        {"client link", kLinkMbit / std::max(mbit(c.client_link_bytes, 1), 1e-9)}};
    const auto first = *std::min_element(limits.begin(), limits.end(),
                                         [](auto& a, auto& b) { return a.second < b.second; });
    carry_table.rows.push_back(
        {std::to_string(p.pods), p.size, p.voxel_mm, p.mode, fixed(limits[0].second),
         fixed(c.server_ms * kTargetFps / 1000),
         fixed(1000 / std::max(c.hull_ms + c.mesh_encode_ms + c.image_encode_ms, 1e-3)),
         fixed(limits[1].second), fixed(limits[2].second),
         fixed(mbit(c.pod_link_bytes, 15)) + " / " + fixed(mbit(c.pod_link_bytes, 30)),
         fixed(mbit(c.client_link_bytes, 15)) + " / " + fixed(mbit(c.client_link_bytes, 30)),
         fixed(100 * c.mesh_bytes / std::max(c.client_link_bytes, 1.0), "%.0f%%"),
         first.first + (first.second < kTargetFps ? " (" + fixed(first.second) + " fps)"
                                                  : " (none below 30 fps)")});
  }
  const html::Table fusion_table = fusionThreadsTable(quick);
  const std::string md =
      "Per point, `holofuse_loop --pods N --size WxH --voxel V --mode M --fps " + fixed(fps, "%g") +
      " --frames " + std::to_string(frames) +
      " --fusion-threads 1`, so that each server stage is one core's work; p50 of each stage "
      "over the run, ms. Server ms per frame: every pod image's decode, "
      "the hull, the mesh encode, the images' encode for clients. Pod: render, segment, feather, "
      "encode. Client: decode, upload, render.\n\n" +
      html::markdownTable(cost_table) +
      "\nWhat each carries alone (frames per second), the links' rates, and the first to stop a "
      "rig at 30 fps (a link counted as 1 Gbit/s; server core fps is every server stage on one "
      "core; fusion fps is the hull and the encodes of one frame after another; a pod's link "
      "carries its own frames, the server's link in all of them; "
      "the pods share this machine's cores, so on a rig with a PC per pod the pod column is a "
      "floor):\n\n" +
      html::markdownTable(carry_table) +
      "\nThe server's fusion (hull, marching cubes, mesh and image encodes) on 1 thread and on "
      "more (`--fusion-threads`), in one process on the same groups of the synthetic subject "
      "handed over all at once: ms per fused frame, the best of five rounds taken in turn, and "
      "its ratio to 1 thread:\n\n" +
      html::markdownTable(fusion_table);
  std::printf("%s", md.c_str());
  if (!markdown.empty()) {
    std::ofstream file(markdown);
    file << md;
    if (!file) {
      std::fprintf(stderr, "--markdown %s: cannot write\n", markdown.c_str());
      return 1;
    }
  }
  return 0;
}
