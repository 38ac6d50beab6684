// bench_gpu: the GPU check in one command (`./holofuse bench gpu`, issue
// 46), sized to run within a few minutes on a GPU host. It runs the live
// loop (holofuse_loop: pods, server and a client as real processes) with
// the pods at 30 fps for two rigs, 4 pods at 320x240 with a 20 mm hull and
// 8 pods at 640x480 with a 10 mm hull, in modes normal and montage4d, and
// then bench_texture_fields (montage4d against holoportation per new
// mesh), and writes what they measured against the targets into one page
// (docs/results/gpu.md by default): frames per second >= 29 and
// end-to-end p95 <= 100 ms at each point, montage4d / holoportation per
// new mesh <= 1.25. On a machine without a GPU it runs the same on the
// CPU device and says so in the page.
//   bench_gpu [--frames F] [--meshes M] [--quick] [--out DIR] [--markdown FILE]
#include <CLI/CLI.hpp>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "base/process.h"
#include "loop_run.h"
#include "report/html.h"

namespace fs = std::filesystem;
using nlohmann::ordered_json;
using namespace holofuse;

namespace {

constexpr double kTargetFps = 29, kTargetP95Ms = 100, kTargetMeshRatio = 1.25;
constexpr const char* kRatioLine = "montage4d / holoportation per new mesh: ";

struct Point {
  int pods;
  std::string size, voxel_mm;
  std::string hull_device;  // fusion_server --hull-device
};

struct Run {
  Point point;
  std::string mode;
  double fps = 0, p50 = 0, p95 = 0, hull = 0, mesh_encode = 0, render = 0;
  std::string device;
};

double stageP50(const ordered_json& report, const char* stage) {
  const auto& stages = report["latency_ms"]["stages"];
  if (!stages.contains(stage) || stages[stage].value("samples", 0) == 0) return 0;
  return stages[stage]["p50"].get<double>();
}

Run runOf(const Point& point, const std::string& mode, const ordered_json& report) {
  Run run;
  run.point = point;
  run.mode = mode;
  run.fps = report["fps"].get<double>();
  run.p50 = report["latency_ms"]["end_to_end"]["p50"].get<double>();
  run.p95 = report["latency_ms"]["end_to_end"]["p95"].get<double>();
  run.hull = stageP50(report, "hull");
  run.mesh_encode = stageP50(report, "mesh_encode");
  run.render = stageP50(report, "render");
  run.device = report["settings"].value("device", std::string("?"));
  return run;
}

// bench_texture_fields' output and its ratio per new mesh (nullopt: it
// failed or printed none; *error says which).
std::optional<double> textureFieldsRatio(int meshes, const fs::path& out, std::string& text,
                                         std::string* error) {
  const fs::path log = out / "bench_texture_fields.txt";
  SpawnOptions spawn;
  spawn.log_path = log.string();
  const auto pid =
      spawnProcess({bench::programDir() + "/bench_texture_fields", std::to_string(meshes)}, spawn);
  if (!pid.isOk()) {
    *error = pid.status().message();
    return std::nullopt;
  }
  const int status = waitProcess(*pid, -1).value_or(-1);
  std::ifstream in(log);
  std::stringstream all;
  all << in.rdbuf();
  text = all.str();
  const size_t at = text.find(kRatioLine);
  if (status != 0 || at == std::string::npos) {
    *error = "bench_texture_fields exited " + std::to_string(status) + "; see " + log.string();
    return std::nullopt;
  }
  return std::stod(text.substr(at + std::string(kRatioLine).size()));
}

std::string verdict(bool met) { return met ? "met" : "missed"; }

std::string today() {
  char text[16];
  const std::time_t now = std::time(nullptr);
  std::strftime(text, sizeof text, "%Y-%m-%d", std::gmtime(&now));
  return text;
}

std::string page(const std::vector<Run>& runs, double ratio, const std::string& fields_text,
                 const std::string& command, int frames) {
  html::Table table{{"pods", "size", "voxel mm", "hull on", "mode", "fps", "end-to-end p50",
                     "end-to-end p95", "hull", "mesh encode", "render", "target"},
                    {},
                    "rrrllrrrrrrl"};
  bool all_met = true;
  for (const Run& r : runs) {
    const bool met = r.fps >= kTargetFps && r.p95 <= kTargetP95Ms;
    all_met = all_met && met;
    table.rows.push_back({std::to_string(r.point.pods), r.point.size, r.point.voxel_mm,
                          r.point.hull_device, r.mode, html::number("%.1f", r.fps),
                          html::number("%.0f", r.p50), html::number("%.0f", r.p95),
                          html::number("%.1f", r.hull), html::number("%.1f", r.mesh_encode),
                          html::number("%.1f", r.render), verdict(met)});
  }
  const std::string device = runs.empty() ? "?" : runs.front().device;
  const bool cpu_device = device.find("llvmpipe") != std::string::npos;
  std::ostringstream md;
  md << "<!-- Written by ./holofuse bench gpu; do not edit. -->\n"
     << "# The live loop at 30 fps on a GPU host\n\n"
     << "`" << command << "` on " << std::thread::hardware_concurrency() << " cores, Vulkan device "
     << device << ", " << today() << ".\n\n";
  if (cpu_device) {
    md << "**No GPU:** the device is Mesa's CPU rasteriser, so these numbers are this "
          "machine's, not a GPU host's; the targets are a GPU host's.\n\n";
  }
  md << "Each point is `holofuse_loop --pods N --size WxH --voxel V --hull-device D --mode M "
        "--fps 30 --frames "
     << frames
     << "` (the demo's settings otherwise, fusion on every core); fps and end-to-end latency "
        "from the client's report, stage p50s in ms. Target: at least "
     << kTargetFps << " fps with end-to-end p95 at most " << kTargetP95Ms << " ms.\n\n"
     << html::markdownTable(table) << "\n";
  md << "montage4d / holoportation per new mesh (bench_texture_fields): "
     << html::number("%.2f", ratio) << " (target <= " << kTargetMeshRatio
     << "): " << verdict(ratio <= kTargetMeshRatio) << ".\n\n"
     << "Loop targets: " << verdict(all_met) << ".\n\n"
     << "<details><summary>bench_texture_fields, whole</summary>\n\n```\n"
     << fields_text << "```\n\n</details>\n";
  return md.str();
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 150, meshes = 6;
  bool quick = false;
  std::string out = "out/bench-gpu", markdown = "docs/results/gpu.md";
  CLI::App app{"bench_gpu: the live loop at 30 fps and the texture fields' cost, on a GPU host"};
  app.add_option("--frames", frames, "frames each loop renders")->check(CLI::Range(10, 100000));
  app.add_option("--meshes", meshes, "meshes bench_texture_fields renders per mode and round")
      ->check(CLI::Range(2, 100));
  app.add_flag("--quick", quick, "one small point and few meshes (for the tests)");
  app.add_option("--out", out, "where each run goes");
  app.add_option("--markdown", markdown, "the page to write")->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  // The 10 mm point twice: its hull on the CPU's cores and on the device.
  std::vector<Point> points;
  auto add = [&](int pods, const char* size, const char* voxel_mm, const char* hull_device) {
    Point p;
    p.pods = pods;
    p.size = size;
    p.voxel_mm = voxel_mm;
    p.hull_device = hull_device;
    points.push_back(p);
  };
  if (quick) {
    add(2, "96x72", "20", "vulkan");
  } else {
    add(4, "320x240", "20", "cpu");
    add(8, "640x480", "10", "cpu");
    add(8, "640x480", "10", "vulkan");
  }
  const std::vector<std::string> modes = {"normal", "montage4d"};
  std::vector<Run> runs;
  for (const Point& p : points) {
    for (const std::string& mode : modes) {
      std::fprintf(stderr, "\r[bench gpu] loop %zu/%zu: %d pods at %s, %s mm, hull on %s, %s   ",
                   runs.size() + 1, points.size() * modes.size(), p.pods, p.size.c_str(),
                   p.voxel_mm.c_str(), p.hull_device.c_str(), mode.c_str());
      const fs::path dir = fs::path(out) / (std::to_string(p.pods) + "-pods-" + p.size + "-" +
                                            p.voxel_mm + "mm-" + p.hull_device + "-hull-" + mode);
      std::string error;
      const auto report = bench::runLoop(
          {"--pods", std::to_string(p.pods), "--size", p.size, "--voxel",
           html::number("%g", std::stod(p.voxel_mm) / 1000), "--hull-device", p.hull_device,
           "--mode", mode, "--fps", "30", "--frames", std::to_string(quick ? 20 : frames)},
          dir, &error);
      if (!report) {
        std::fprintf(stderr, "\n[bench gpu] %s: %s\n", dir.c_str(), error.c_str());
        return 1;
      }
      runs.push_back(runOf(p, mode, *report));
    }
  }
  std::fprintf(stderr, "\r[bench gpu] bench_texture_fields %d meshes%30s\n", quick ? 2 : meshes,
               "");
  std::string fields_text, error;
  fs::create_directories(out);
  const auto ratio = textureFieldsRatio(quick ? 2 : meshes, out, fields_text, &error);
  if (!ratio) {
    std::fprintf(stderr, "[bench gpu] %s\n", error.c_str());
    return 1;
  }
  std::string command = "./holofuse bench gpu";
  for (int i = 1; i < argc; ++i) command += std::string(" ") + argv[i];
  const std::string md = page(runs, *ratio, fields_text, command, quick ? 20 : frames);
  std::printf("%s", md.c_str());
  if (fs::path(markdown).has_parent_path())
    fs::create_directories(fs::path(markdown).parent_path());
  std::ofstream file(markdown);
  file << md;
  if (!file) {
    std::fprintf(stderr, "--markdown %s: cannot write\n", markdown.c_str());
    return 1;
  }
  std::fprintf(stderr, "[bench gpu] wrote %s\n", markdown.c_str());
  return 0;
}
