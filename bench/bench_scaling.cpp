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
//   - the frames per second each of them carries (and the fusion worker's
//     thread alone, which no further core speeds up), and which is the
//     first to stop a rig at 30 fps (a 1 Gbit/s link counted as one).
//   bench_scaling [--frames F] [--fps R] [--quick] [--out DIR] [--markdown FILE]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "config/command_line.h"
#include "config/rig_shape.h"
#include "loop_run.h"
#include "report/html.h"

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
    const auto report =
        bench::runLoop({"--pods", std::to_string(p.pods), "--size", p.size, "--voxel",
                        fixed(std::stod(p.voxel_mm) / 1000, "%g"), "--mode", p.mode, "--fps",
                        fixed(fps, "%g"), "--frames", std::to_string(frames)},
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
      {"pods", "size", "voxel mm", "mode", "server core fps", "cores for 30 fps", "worker fps",
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
  const std::string md =
      "Per point, `holofuse_loop --pods N --size WxH --voxel V --mode M --fps " + fixed(fps, "%g") +
      " --frames " + std::to_string(frames) +
      "`; p50 of each stage over the run, ms. Server ms per frame: every pod image's decode, "
      "the hull, the mesh encode, the images' encode for clients. Pod: render, segment, feather, "
      "encode. Client: decode, upload, render.\n\n" +
      html::markdownTable(cost_table) +
      "\nWhat each carries alone (frames per second), the links' rates, and the first to stop a "
      "rig at 30 fps (a link counted as 1 Gbit/s; server core fps is every server stage on one "
      "core; worker fps is the fusion worker's thread alone, hull and encodes, which no second "
      "core speeds up; a pod's link carries its own frames, the server's link in all of them; "
      "the pods share this machine's cores, so on a rig with a PC per pod the pod column is a "
      "floor):\n\n" +
      html::markdownTable(carry_table);
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
