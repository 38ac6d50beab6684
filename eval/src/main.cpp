// holofuse_eval: leave-one-camera-out quality of every blending mode on the
// named synthetic scenes. See docs/evaluation.md.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>

#include "config/command_line.h"
#include "eval/knobs.h"
#include "eval/leave_one_out.h"
#include "protocol/messages.h"
#include "render_client/render_settings.h"

int main(int argc, char** argv) {
  using namespace holofuse;
  eval::EvalOptions options;
  std::vector<std::string> modes;
  std::string size = "320x240";
  CLI::App app{
      "holofuse eval: leave-one-camera-out quality (RMSE, PSNR, SSIM, flicker) per scene and mode"};
  app.add_option("--scenes", options.scenes, "scenes (default: all): " + scene::sceneNames())
      ->delimiter(',');
  app.add_option("--modes", modes,
                 "blending modes (default: all): normal, holoportation, montage4d, fragment")
      ->delimiter(',')
      ->check(CLI::IsMember(render::blendModeNames()));
  app.add_option("--dataset", options.datasets,
                 "dataset folder(s), recorded or imported, evaluated like scenes")
      ->delimiter(',');
  app.add_option("--frames", options.frames, "frames per scene")->check(CLI::Range(1, 10000));
  app.add_option("--first-frame", options.first_frame, "first frame id (scene time = id / 10 s)");
  app.add_option("--size", size, "camera and output size WxH");
  app.add_option("--held-out", options.held_out_cameras,
                 "held-out cameras per scene, evenly spread (0: all)")
      ->check(CLI::Range(0, static_cast<int>(protocol::kMaxCameras)));
  app.add_option("--out", options.out_dir, "output folder (quality.json, quality.md, images/)")
      ->required();
  app.add_flag("--save-images", options.save_images,
               "write rendered, true and mask PNGs of every comparison");
  // Every setting a sweep turns, under the live loop's flag names (--size
  // is eval's own, above).
  const SettingFlags<eval::EvalOptions> setting_flags(app, eval::evalFlags());
  app.add_option("--novel-views", options.novel_view_degrees,
                 "synthetic scenes: also render this many degrees around the ring from the chosen "
                 "cameras' poses, "
                 "every camera blended, against the scene's true image there (one row per offset)")
      ->delimiter(',');
  app.add_flag(
      "--camera-kept", options.camera_kept,
      "also score each chosen camera's own pose with its image kept in the blend (one more row per "
      "scene; paper 000's Table 2 numbers need it; outside the target's protocol)");
  app.add_flag("--hull-without-held-out", options.hull_without_held_out,
               "leave the held-out camera's silhouette out of the hull too (carved again for each "
               "held-out camera): "
               "nothing of it shapes what its image is compared with");
  app.add_option("--geometry", options.geometry,
                 "hull (the server's visual hull) or truth (the true surface)")
      ->check(CLI::IsMember({"hull", "truth"}));
  // The client's --device and --budget, from its table.
  auto client_settings = pickSettings(render::clientRunFlags(), {"--device", "--budget"});
  client_settings.back().help += "; here the p95 of " + eval::budgetedStagesText();
  const SettingFlags<render::ClientRunSettings> client_flags(app, client_settings);
  HOLOFUSE_PARSE_FLAGS(app, argc, argv)
  render::ClientRunSettings client;
  client_flags.apply(client);
  options.device = client.device;
  auto loaded_budget = protocol::loadBudgetFlag(client.budget);
  if (!loaded_budget.isOk()) {
    std::fprintf(stderr, "%s\n", loaded_budget.status().message().c_str());
    return 2;
  }
  options.budget = *loaded_budget;
  setting_flags.apply(options);
  for (size_t k = 0; k < options.novel_view_degrees.size(); ++k) {
    const double degrees = options.novel_view_degrees[k];
    if (std::count(options.novel_view_degrees.begin(), options.novel_view_degrees.begin() + k,
                   degrees) > 0) {
      std::fprintf(stderr, "holofuse eval: --novel-views %g is given twice\n", degrees);
      return 2;
    }
    if (!(degrees != 0 && std::abs(degrees) < 360)) {
      std::fprintf(stderr,
                   "holofuse eval: --novel-views %g: an offset must be nonzero and within (-360, "
                   "360) degrees "
                   "(0 is the camera's own pose: leave-one-out covers it)\n",
                   degrees);
      return 2;
    }
  }
  unsigned w = 0, h = 0;
  if (const std::string error = parseImageSize(size, w, h); !error.empty()) {
    std::fprintf(stderr, "holofuse eval: --size %s\n", error.c_str());
    return 2;
  }
  options.width = w;
  options.height = h;
  for (const auto& scene : options.scenes) {
    if (scene::findScene(scene) == nullptr) {
      std::fprintf(stderr, "--scenes: unknown scene '%s'; valid scenes: %s\n", scene.c_str(),
                   scene::sceneNames().c_str());
      return 2;
    }
  }
  if (!modes.empty()) {
    options.modes.clear();
    for (const auto& name : modes) {
      if (auto mode = render::blendModeFromName(name))
        options.modes.push_back(*mode);  // names checked by CLI11
    }
  }
  try {
    const auto start = std::chrono::steady_clock::now();
    const auto results = eval::runLeaveOneOut(options, [](const std::string& line) {
      std::printf("[eval] %s\n", line.c_str());
      std::fflush(stdout);
    });
    if (!results.isOk()) {
      std::fprintf(stderr, "[eval] %s\n", results.status().message().c_str());
      return 1;
    }
    if (const Status written = eval::writeQualityReports(options, *results, options.out_dir);
        !written.isOk()) {
      std::fprintf(stderr, "[eval] %s\n", written.message().c_str());
      return 1;
    }
    std::printf("[eval] %zu scenes in %.0f s; wrote %s/quality.json and quality.md\n",
                results->size(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                options.out_dir.c_str());
  } catch (const std::exception& e) {
    // The device failing mid-run (the renderer throws on a Vulkan error):
    // not the evaluation's input, and nothing of it can go on.
    std::fprintf(stderr, "[eval] %s\n", e.what());
    return 1;
  }
  return 0;
}
