// holofuse_sweep: the speed/accuracy trade, one knob at a time. See
// docs/sweep.md.
#include <cstdio>
#include <exception>
#include <filesystem>
#include <optional>

#include "config/command_line.h"
#include "eval/sweep.h"
#include "protocol/messages.h"
#include "render_client/render_settings.h"

int main(int argc, char** argv) {
  using namespace holofuse;
  eval::SweepOptions options;
  options.base.frames = 4;
  options.base.held_out_cameras = 2;
  options.base.modes = {render::BlendMode::kHoloportation, render::BlendMode::kMontage4D};
  std::vector<std::string> knob_texts, modes;
  std::string scene = "clean";
  CLI::App app{
      "holofuse sweep: quality against time and bytes, one knob at a time around the defaults"};
  app.add_option("--knob", knob_texts, "NAME=v1,v2,... (repeatable); knobs: " + eval::knobNames())
      ->required();
  auto* scene_flag = app.add_option("--scene", scene, "scene: " + scene::sceneNames());
  std::string dataset;
  app.add_option("--dataset", dataset,
                 "a dataset folder (recorded or imported) to sweep instead of a scene; live points "
                 "replay it")
      ->excludes(scene_flag);
  app.add_option("--modes", modes, "modes measured; the last is the one whose quality is plotted")
      ->delimiter(',')
      ->check(CLI::IsMember(render::blendModeNames()));
  app.add_option("--frames", options.base.frames, "frames per point")->check(CLI::Range(1, 1000));
  app.add_option("--held-out", options.base.held_out_cameras, "held-out cameras per point (0: all)")
      ->check(CLI::Range(0, static_cast<int>(protocol::kMaxCameras)));
  app.add_option("--out", options.out_dir,
                 "output folder (points/, sweep.json, sweep.md, sweep.html)")
      ->required();
  // The client's --device and --budget, from its table.
  auto client_settings = pickSettings(render::clientRunFlags(), {"--device", "--budget"});
  client_settings.back().help += "; here the p95 of " + eval::budgetedStagesText();
  const SettingFlags<render::ClientRunSettings> client_flags(app, client_settings);
  std::vector<std::string> set_texts;
  app.add_option("--set", set_texts,
                 "NAME=VALUE (repeatable): move the sweep's base (the defaults every point starts "
                 "from) by a knob, "
                 "e.g. --set size=640x480 --knob draco-bits=8,11,14");
  app.add_option("--live-frames", options.live_frames,
                 "also run each point in the live loop (real processes on loopback) for this many "
                 "frames and "
                 "judge its end-to-end latency too (0: no live runs)")
      ->check(CLI::Range(0, 100000));
  HOLOFUSE_PARSE_FLAGS(app, argc, argv)
  render::ClientRunSettings client;
  client_flags.apply(client);
  options.base.device = client.device;
  auto loaded_budget = protocol::loadBudgetFlag(client.budget);
  if (!loaded_budget.isOk()) {
    std::fprintf(stderr, "%s\n", loaded_budget.status().message().c_str());
    return 2;
  }
  options.base.budget = *loaded_budget;
  if (dataset.empty()) {
    options.base.scenes = {scene};
  } else {
    options.base.datasets = {dataset};
  }
  // The live loop's launcher lies next to this executable.
  options.loop_program =
      (std::filesystem::canonical("/proc/self/exe").parent_path() / "holofuse_loop").string();
  if (dataset.empty() && scene::findScene(scene) == nullptr) {
    std::fprintf(stderr, "--scene: unknown scene '%s'; valid scenes: %s\n", scene.c_str(),
                 scene::sceneNames().c_str());
    return 2;
  }
  if (!modes.empty()) {
    options.base.modes.clear();
    for (const auto& name : modes) {
      if (auto mode = render::blendModeFromName(name))
        options.base.modes.push_back(*mode);  // names checked by CLI11
    }
  }
  for (const auto& text : set_texts) {
    const size_t eq = text.find('=');
    const eval::Knob* knob = eq == std::string::npos ? nullptr : eval::findKnob(text.substr(0, eq));
    if (knob == nullptr) {
      std::fprintf(stderr, "--set '%s': expected NAME=VALUE with a knob's name; knobs: %s\n",
                   text.c_str(), eval::knobNames().c_str());
      return 2;
    }
    if (const std::string error = knob->apply(options.base, text.substr(eq + 1)); !error.empty()) {
      std::fprintf(stderr, "--set %s: %s\n", knob->name.c_str(), error.c_str());
      return 2;
    }
  }
  for (const auto& text : knob_texts) {
    const size_t eq = text.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == text.size()) {
      std::fprintf(stderr, "--knob '%s': expected NAME=v1,v2,...; knobs: %s\n", text.c_str(),
                   eval::knobNames().c_str());
      return 2;
    }
    std::vector<std::string> values;
    size_t start = eq + 1;
    while (start <= text.size()) {
      const size_t comma = text.find(',', start);
      values.push_back(
          text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
    options.knobs.emplace_back(text.substr(0, eq), values);
  }
  std::optional<StatusOr<std::vector<eval::SweepPoint>>> swept;
  try {
    swept = eval::runSweep(options, [](const std::string& line) {
      std::printf("[sweep] %s\n", line.c_str());
      std::fflush(stdout);
    });
  } catch (const std::exception& e) {
    // The device failing mid-run (the renderer throws on a Vulkan error);
    // the points finished before it stay on disk.
    std::fprintf(stderr, "[sweep] %s\n", e.what());
    return 1;
  }
  const auto& points = *swept;
  if (!points.isOk()) {
    std::fprintf(stderr, "[sweep] %s\n", points.status().message().c_str());
    // What was asked for is wrong (2), or a run or a write failed (1).
    return points.status().code() == StatusCode::kMalformed ? 2 : 1;
  }
  if (const Status written = eval::writeSweepReports(options, *points); !written.isOk()) {
    std::fprintf(stderr, "[sweep] %s\n", written.message().c_str());
    return 1;
  }
  std::printf("[sweep] %zu points; wrote %s/sweep.json, sweep.md and sweep.html\n", points->size(),
              options.out_dir.c_str());
  return 0;
}
