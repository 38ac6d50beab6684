// ./holofuse bench viewer: what the client's window costs its render. The
// live loop (holofuse_loop: pods, server, client as real processes on
// loopback) runs the same frames with --window on under an Xvfb display of
// its own and headless, alternately, several times; each run's report.json
// gives the client's render p50 (which ends once the picture, under the
// live panel, is handed to the window), fps and end to end. Issue 47's
// target: the window adds at most 10% to the render p50. Ratios are taken
// per pair of neighbouring runs, since the machine's load drifts.
//   bench_viewer [--modes M,N] [--frames F] [--repeats R] [--out DIR]
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "base/process.h"
#include "bench_timing.h"
#include "loop_run.h"

namespace fs = std::filesystem;
using namespace holofuse;

namespace {

constexpr double kTargetRatio = 1.10;

struct Run {
  double render_p50 = 0, fps = 0, end_to_end_p50 = 0;
};

std::optional<Run> readRun(const nlohmann::ordered_json& report, std::string* error) {
  try {
    const auto& latency = report.at("latency_ms");
    return Run{latency.at("stages").at("render").at("p50").get<double>(),
               report.at("fps").get<double>(), latency.at("end_to_end").at("p50").get<double>()};
  } catch (const nlohmann::json::exception& e) {
    *error = std::string("report.json without the render stage: ") + e.what();
    return std::nullopt;
  }
}

// An X display of this run's own (Xvfb), or -1 with why.
int startDisplay(std::string* display, std::string* why) {
  if (!fs::exists("/usr/bin/Xvfb")) {
    *why = "no /usr/bin/Xvfb (Debian package xvfb)";
    return -1;
  }
  int number = 90 + static_cast<int>(::getpid() % 50);
  while (fs::exists("/tmp/.X11-unix/X" + std::to_string(number))) ++number;
  *display = ":" + std::to_string(number);
  SpawnOptions options;
  options.log_path = "/dev/null";
  options.die_with_parent = true;
  const auto pid = spawnProcess(
      {"/usr/bin/Xvfb", *display, "-screen", "0", "1024x768x24", "-nolisten", "tcp"}, options);
  if (!pid.isOk()) {
    *why = pid.status().message();
    return -1;
  }
  // Xvfb opens its socket once it serves; a start-up, not a measurement.
  for (int i = 0; i < 100 && !fs::exists("/tmp/.X11-unix/X" + std::to_string(number)); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  if (!fs::exists("/tmp/.X11-unix/X" + std::to_string(number))) {
    *why = "Xvfb " + *display + " did not start";
    return -1;
  }
  return static_cast<int>(*pid);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"bench_viewer: the client's render with its window against headless"};
  std::vector<std::string> modes = {"normal", "montage4d"};
  int frames = 40, repeats = 3;
  std::string out = "out/bench_viewer";
  app.add_option("--modes", modes, "blending modes, comma-separated")->delimiter(',');
  app.add_option("--frames", frames, "frames per run")->check(CLI::Range(5, 100000));
  app.add_option("--repeats", repeats, "pairs of runs (window, headless) per mode")
      ->check(CLI::Range(1, 50));
  app.add_option("--out", out, "folder of the runs");
  CLI11_PARSE(app, argc, argv);

  std::string display, why;
  const int xvfb = startDisplay(&display, &why);
  if (xvfb < 0) {
    std::fprintf(stderr, "bench_viewer: no display for the window: %s\n", why.c_str());
    return 2;
  }
  std::printf("bench_viewer: %d frames a run, %d pairs per mode, the window on Xvfb %s\n\n", frames,
              repeats, display.c_str());
  std::printf("%-12s %16s %16s %10s %14s %14s %14s\n", "mode", "render p50 win", "headless",
              "win / hl", "fps win / hl", "e2e p50 win", "headless");
  bool met = true;
  for (const std::string& mode : modes) {
    std::vector<double> ratios, fps_ratios;
    std::vector<double> window_render, headless_render, window_e2e, headless_e2e;
    for (int r = 0; r < repeats; ++r) {
      Run pair[2];
      // Alternate which goes first, so that a drift in load favours neither.
      for (int k = 0; k < 2; ++k) {
        const bool window = (k + r) % 2 == 0;
        if (window) {
          ::setenv("DISPLAY", display.c_str(), 1);
        } else {
          ::unsetenv("DISPLAY");
        }
        std::vector<std::string> flags = {"--mode", mode, "--frames", std::to_string(frames)};
        if (window) flags.insert(flags.end(), {"--window", "on"});
        const fs::path dir =
            fs::path(out) / (mode + (window ? "_window_" : "_headless_") + std::to_string(r));
        std::string error;
        const auto report = bench::runLoop(flags, dir, &error);
        const auto run = report ? readRun(*report, &error) : std::nullopt;
        if (!run) {
          std::fprintf(stderr, "bench_viewer: %s %s: %s\n", mode.c_str(),
                       window ? "with the window" : "headless", error.c_str());
          stopProcess(xvfb, 2000);
          return 1;
        }
        std::ifstream log(dir / "logs" / "client.log");
        const std::string said((std::istreambuf_iterator<char>(log)),
                               std::istreambuf_iterator<char>());
        if (window &&
            said.find("[client] the pictures show in a window too") == std::string::npos) {
          std::fprintf(stderr, "bench_viewer: the client opened no window; see %s\n",
                       (dir / "logs" / "client.log").c_str());
          stopProcess(xvfb, 2000);
          return 1;
        }
        pair[window ? 0 : 1] = *run;
      }
      ratios.push_back(pair[0].render_p50 / pair[1].render_p50);
      fps_ratios.push_back(pair[0].fps / pair[1].fps);
      window_render.push_back(pair[0].render_p50);
      headless_render.push_back(pair[1].render_p50);
      window_e2e.push_back(pair[0].end_to_end_p50);
      headless_e2e.push_back(pair[1].end_to_end_p50);
    }
    const double ratio = bench::median(ratios);
    met = met && ratio <= kTargetRatio;
    std::printf("%-12s %13.1f ms %13.1f ms %10.3f %14.3f %11.1f ms %11.1f ms\n", mode.c_str(),
                bench::median(window_render), bench::median(headless_render), ratio,
                bench::median(fps_ratios), bench::median(window_e2e), bench::median(headless_e2e));
  }
  stopProcess(xvfb, 2000);
  std::printf(
      "\nwin / hl: the median over the pairs of render p50 with the window over headless "
      "(target <= %.2f: %s)\n",
      kTargetRatio, met ? "met" : "MISSED");
  return 0;
}
