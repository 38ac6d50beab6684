// quality.json, quality.md and quality.html of an evaluation: the tables
// and charts of every scene and mode, with the settings they ran with.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>

#include "base/text_file.h"
#include "eval/leave_one_out.h"
#include "metrics/image_metrics.h"
#include "report/html.h"
#include "result_json.h"

namespace holofuse::eval {
namespace {

namespace fs = std::filesystem;

using metrics::ErrorRegion;
using metrics::errorRegionName;
using metrics::kErrorRegionCount;
using metrics::psnrFromMse;
using metrics::RegionErrors;

// What the verdict tables' "pictures differ on" column says.
constexpr const char* kPicturesDifferMeaning =
    "Pictures differ on: the share of the compared pixels where montage4d's picture differs from "
    "holoportation's "
    "by more than 2 grey levels, and (in brackets) the PSNR gain montage4d would have if exact on "
    "every one of them: "
    "the most that what its fields change could gain, at these settings (other settings change "
    "other pixels).";

// Per scene (novel-view and camera-kept rows share their scene's frames):
// bytes per frame on each link and the codecs' ms, as report cells.
std::vector<std::vector<std::string>> linkRows(const std::vector<SceneResult>& results) {
  std::vector<std::vector<std::string>> rows;
  for (const auto& scene : results) {
    if (scene.novel_view_degrees != 0 || scene.camera_kept) continue;
    char cells[5][32];
    std::snprintf(cells[0], sizeof(cells[0]), "%.1f", scene.pod_link_bytes_per_frame / 1000.0);
    std::snprintf(cells[1], sizeof(cells[1]), "%.1f", scene.bytes_per_frame / 1000.0);
    std::snprintf(cells[2], sizeof(cells[2]), "%.1f", scene.feather_bytes_per_frame / 1000.0);
    std::snprintf(cells[3], sizeof(cells[3]), "%.1f", scene.codec_ms);
    std::snprintf(cells[4], sizeof(cells[4]), "%.1f", scene.codec_ms_p95);
    rows.push_back({scene.name, cells[0], cells[1], cells[2], cells[3], cells[4]});
  }
  return rows;
}

}  // namespace

std::vector<std::string> latencyStages() {
  std::vector<std::string> stages = {"hull", "refine"};
  stages.insert(stages.end(), codecStages().begin(), codecStages().end());
  stages.push_back("client render");
  return stages;
}

std::vector<double> latencyParts(const SceneResult& scene, const ModeResult& mode, bool p95) {
  std::vector<double> parts = {p95 ? scene.hull_ms_p95 : scene.hull_ms,
                               p95 ? scene.refine_ms_p95 : scene.refine_ms};
  const auto& codec_ms = p95 ? scene.codec_stage_ms_p95 : scene.codec_stage_ms;
  for (const std::string& stage : codecStages())
    parts.push_back(codec_ms.count(stage) ? codec_ms.at(stage) : 0.0);
  parts.push_back(p95 ? mode.ms_per_new_mesh_p95 : mode.ms_per_new_mesh);
  return parts;
}

namespace {

using Rows = std::vector<std::vector<std::string>>;

// Scenes whose renders are their own: novel-view and camera-kept rows
// share their scene's frames and timings.
bool ownRenders(const SceneResult& scene) {
  return scene.novel_view_degrees == 0 && !scene.camera_kept;
}

// Every table of the report, built once and written as Markdown and HTML.
struct QualityTables {
  std::vector<std::string> modes;
  html::Table rates, flicker, layers, regions, geometry, segmentation, links, verdicts;
  // Paper 000 Table 3's layout, one table per scene.
  std::vector<std::pair<std::string, html::Table>> stages;
  // Each budgeted stage at p95 ("!" first where over), what is over, and
  // the budget's stages the evaluation does not time.
  Rows budget_rows;
  nlohmann::json violations = nlohmann::json::array();
  nlohmann::json unchecked_stages = nlohmann::json::array();
  std::string unchecked_text;
};

// One column per mode and measure, a row per scene.
html::Table modeTable(const std::vector<SceneResult>& results,
                      const std::vector<std::string>& modes,
                      const std::vector<std::string>& measures,
                      const std::function<std::vector<std::string>(const ModeResult&)>& cells) {
  html::Table table{{"Scene"}, {}, ""};
  for (const auto& mode : modes) {
    for (const auto& measure : measures) table.header.push_back(mode + " " + measure);
  }
  for (const auto& scene : results) {
    std::vector<std::string> row = {scene.name};
    for (const auto& mode : modes) {
      const auto it = scene.modes.find(mode);
      for (size_t i = 0; i < measures.size(); ++i)
        row.push_back(it == scene.modes.end() ? std::string() : cells(it->second).at(i));
    }
    table.rows.push_back(std::move(row));
  }
  return table;
}

// PSNR per error region, with each region's share of the squared-error
// difference from normal, and a row of each region's share of the pixels.
html::Table regionTable(const std::vector<SceneResult>& results,
                        const std::vector<std::string>& modes) {
  html::Table regions{{"Scene", "mode"}, {}, std::string(2 + kErrorRegionCount, 'l')};
  for (size_t r = 0; r < kErrorRegionCount; ++r)
    regions.header.push_back(errorRegionName(static_cast<ErrorRegion>(r)));
  for (const auto& scene : results) {
    if (scene.modes.empty()) continue;
    // Every mode compares the same pixels.
    const RegionErrors& any = scene.modes.begin()->second.regions;
    double all_pixels = 0;
    for (size_t count : any.pixels) all_pixels += static_cast<double>(count);
    std::vector<std::string> pixels = {scene.name, "pixels"};
    for (size_t count : any.pixels) {
      pixels.push_back(html::number(
          "%.1f%%", all_pixels > 0 ? 100.0 * static_cast<double>(count) / all_pixels : 0.0));
    }
    regions.rows.push_back(std::move(pixels));
    for (const auto& mode : modes) {
      const auto it = scene.modes.find(mode);
      if (it == scene.modes.end()) continue;
      const auto shares = regionSharesAgainstNormal(scene.modes, mode);
      std::vector<std::string> row = {scene.name, mode};
      for (size_t r = 0; r < kErrorRegionCount; ++r) {
        const char* name = errorRegionName(static_cast<ErrorRegion>(r));
        const double samples = 3.0 * static_cast<double>(it->second.regions.pixels[r]);
        if (samples == 0) {
          row.push_back("n/a");
          continue;
        }
        std::string text =
            html::number("%.2f dB", psnrFromMse(it->second.regions.squared_error[r] / samples));
        if (shares.count(name)) text += html::number(" (%+.0f%%)", 100.0 * shares.at(name));
        row.push_back(std::move(text));
      }
      regions.rows.push_back(std::move(row));
    }
  }
  return regions;
}

html::Table geometryTable(const std::vector<SceneResult>& results) {
  html::Table geometry{
      {"Scene", "voxel mm", "triangles", "hull ms", "cells visited", "dense grid points",
       "Chamfer mm", "silhouette error mm", "IoU mean", "IoU worst"},
      {},
      ""};
  for (const auto& scene : results) {
    double mean_iou = 0, worst_iou = 1;
    for (double v : scene.silhouette_iou) {
      mean_iou += v / static_cast<double>(scene.silhouette_iou.size());
      worst_iou = std::min(worst_iou, v);
    }
    geometry.rows.push_back(
        {scene.name, html::number("%.1f", scene.voxel_mm), html::number("%.0f", scene.triangles),
         html::number("%.1f", scene.hull_ms), html::number("%.0f", scene.cells_visited),
         html::number("%.0f", scene.dense_grid_points),
         scene.chamfer_mm >= 0 ? html::number("%.1f", scene.chamfer_mm) : "n/a (no true surface)",
         scene.silhouette_error_mm >= 0 ? html::number("%.2f", scene.silhouette_error_mm) : "n/a",
         html::number("%.3f", mean_iou), html::number("%.3f", worst_iou)});
  }
  return geometry;
}

// The pods' masks against the truth, where the scene has one.
html::Table segmentationTable(const std::vector<SceneResult>& results) {
  html::Table segmentation{
      {"Scene", "mask IoU mean", "mask IoU worst camera", "with the rig's agreement: mean",
       "worst camera", "shadow taken for the subject"},
      {},
      ""};
  // The mean over cameras and the worst camera of per-camera IoUs.
  auto meanAndWorst = [](const std::vector<double>& iou) -> std::pair<std::string, std::string> {
    if (iou.empty()) return {"n/a", "n/a"};
    double mean = 0, worst = 1;
    for (double v : iou) {
      mean += v / static_cast<double>(iou.size());
      worst = std::min(worst, v);
    }
    return {html::number("%.3f", mean), html::number("%.3f", worst)};
  };
  for (const auto& scene : results) {
    if (scene.mask_iou.empty()) continue;
    const auto [alone_mean, alone_worst] = meanAndWorst(scene.mask_iou);
    const auto [agreed_mean, agreed_worst] = meanAndWorst(scene.mask_iou_agreed);
    segmentation.rows.push_back({scene.name, alone_mean, alone_worst, agreed_mean, agreed_worst,
                                 scene.shadow_taken >= 0
                                     ? html::number("%.2f%%", 100 * scene.shadow_taken)
                                     : "n/a (no shadow)"});
  }
  return segmentation;
}

html::Table verdictTable(const std::vector<SceneResult>& results) {
  html::Table verdicts{{"Scene", "PSNR gain", "SSIM gain", "flicker ratio",
                        "pictures differ on (gain if exact there)", "verdict"},
                       {},
                       "lrrrrl"};
  for (const auto& scene : results) {
    const Verdict v = montageVerdict(scene);
    if (scene.modes.count("holoportation") == 0 || scene.modes.count("montage4d") == 0) continue;
    const bool novel = scene.novel_view_degrees != 0;
    const bool target = scene.name != "clean" && !novel && !scene.camera_kept;
    const std::string verdict =
        novel ? std::string("novel view (all pods blended): outside the target's protocol")
        : scene.camera_kept
            ? std::string(
                  "camera kept in the blend (paper 000 Table 2's reach): outside the "
                  "target's protocol")
        : !target ? std::string("baseline, not a target")
        : v.met   ? std::string("met")
                  : "MISSED: " + v.why;
    std::string differ = "n/a";
    if (v.agreement.measured) {
      differ = html::number("%.1f%%", 100 * v.agreement.differing_share) +
               html::number(" (%+.2f dB)", v.agreement.gain_bound_db);
    }
    verdicts.rows.push_back({(target && !v.met ? "!" : "") + scene.name,
                             html::number("%+.2f dB", v.psnr_gain_db),
                             html::number("%+.4f", v.ssim_gain),
                             measuredText(v.flicker_ratio, "%.2f"), differ, verdict});
  }
  return verdicts;
}

// Paper 000 Table 3's layout: per scene, the GPU passes of a new mesh
// (timestamps, medians) as rows and the modes as columns, then the wall
// clock of that render. normal mode runs no field passes.
std::vector<std::pair<std::string, html::Table>> stageTables(
    const std::vector<SceneResult>& results, const std::vector<std::string>& modes) {
  std::vector<std::pair<std::string, html::Table>> tables;
  std::vector<std::string> header = {"stage"};
  header.insert(header.end(), modes.begin(), modes.end());
  for (const auto& scene : results) {
    if (!ownRenders(scene)) continue;
    std::vector<std::string> stages;  // in pipeline order
    for (const auto& stage : render::TextureFieldPasses::stageNames()) {
      for (const auto& mode : modes) {
        const auto it = scene.modes.find(mode);
        if (it != scene.modes.end() && it->second.gpu_passes_ms.count(stage) &&
            std::find(stages.begin(), stages.end(), stage) == stages.end()) {
          stages.push_back(stage);
        }
      }
    }
    auto row = [&](const std::string& label,
                   const std::function<double(const ModeResult&)>& value) {
      std::vector<std::string> cells = {label};
      for (const auto& mode : modes) {
        const auto it = scene.modes.find(mode);
        const double v = it == scene.modes.end() ? -1.0 : value(it->second);
        cells.push_back(v >= 0 ? html::number("%.2f", v) : "-");
      }
      return cells;
    };
    html::Table table{header, {}, ""};
    for (const auto& stage : stages) {
      table.rows.push_back(row(stage, [&](const ModeResult& m) {
        const auto it = m.gpu_passes_ms.find(stage);
        return it == m.gpu_passes_ms.end() ? -1.0 : it->second;
      }));
    }
    table.rows.push_back(row("field passes, total", [](const ModeResult& m) {
      double total = 0;
      for (const auto& [stage, ms] : m.gpu_passes_ms) total += ms;
      return m.gpu_passes_ms.empty() ? -1.0 : total;
    }));
    table.rows.push_back(row("render after a new mesh (wall clock)",
                             [](const ModeResult& m) { return m.ms_per_new_mesh; }));
    tables.emplace_back(scene.name, std::move(table));
  }
  return tables;
}

// The budget (options.budget): each scene's hull and each mode's render,
// at p95, against it. A budget's stages the evaluation does not time
// (end_to_end, the transport, the pods' rendering...) are named, not
// passed over in silence.
void checkBudgets(const EvalOptions& options, const std::vector<SceneResult>& results,
                  QualityTables& tables) {
  for (const auto& scene : results) {
    if (!ownRenders(scene)) continue;
    for (const BudgetCheck& check : checkBudget(options.budget, scene, tables.modes)) {
      tables.budget_rows.push_back({(check.over() ? "!" : "") + scene.name, check.mode, check.stage,
                                    html::number("%.1f", check.p95_ms),
                                    html::number("%.1f", check.budget_ms)});
      if (check.over()) {
        tables.violations.push_back({{"scene", scene.name},
                                     {"mode", check.mode},
                                     {"stage", check.stage},
                                     {"p95_ms", check.p95_ms},
                                     {"budget_ms", check.budget_ms}});
      }
    }
  }
  std::string unchecked;
  const std::vector<std::string> budgeted = budgetedStages();
  for (const auto& [stage, ms] : options.budget) {
    if (std::find(budgeted.begin(), budgeted.end(), stage) != budgeted.end()) continue;
    unchecked += (unchecked.empty() ? "" : ", ") + stage;
    tables.unchecked_stages.push_back(stage);
  }
  if (!unchecked.empty()) {
    tables.unchecked_text =
        " Not timed here, so not checked (the live loop's report checks them): " + unchecked + ".";
  }
}

QualityTables qualityTables(const EvalOptions& options, const std::vector<SceneResult>& results) {
  QualityTables t;
  for (auto mode : options.modes) t.modes.push_back(render::blendModeName(mode));
  t.rates = modeTable(
      results, t.modes, {"RMSE", "PSNR", "SSIM", "fps"},
      [](const ModeResult& m) -> std::vector<std::string> {
        return {html::number("%.2f%%", m.rmse_percent), html::number("%.2f dB", m.psnr_db),
                html::number("%.4f", m.ssim),
                html::number("%.1f", m.ms_per_new_mesh > 0 ? 1000.0 / m.ms_per_new_mesh : 0.0)};
      });
  t.flicker = modeTable(
      results, t.modes, {"flicker", "seams"}, [](const ModeResult& m) -> std::vector<std::string> {
        return {measuredText(m.flicker, "%.2f"), measuredText(m.seam_visibility, "%.2f")};
      });
  t.layers =
      modeTable(results, t.modes,
                {"KB/frame", "mesh KB", "layer colour KB", "camera planes KB", "charts moved",
                 "layers ms", "video ms"},
                [](const ModeResult& m) -> std::vector<std::string> {
                  const bool layered = m.layers_ms > 0;
                  auto kb = [&](double bytes) {
                    return layered ? html::number("%.1f", bytes / 1000.0) : std::string("-");
                  };
                  return {html::number("%.1f", m.client_bytes_per_frame / 1000.0),
                          html::number("%.1f", m.mesh_bytes_per_frame / 1000.0),
                          kb(m.layer_colour_bytes_per_frame),
                          kb(m.layer_camera_bytes_per_frame),
                          m.atlas_moved >= 0 ? html::number("%.0f%%", 100 * m.atlas_moved) : "-",
                          layered ? html::number("%.1f", m.layers_ms) : "-",
                          m.layer_video_ms > 0 ? html::number("%.1f", m.layer_video_ms) : "-"};
                });
  t.regions = regionTable(results, t.modes);
  t.geometry = geometryTable(results);
  t.segmentation = segmentationTable(results);
  t.links = {{"Scene", "pods to server KB", "server to client KB", "of which feather maps KB",
              "codecs ms p50", "p95"},
             linkRows(results),
             ""};
  t.verdicts = verdictTable(results);
  t.stages = stageTables(results, t.modes);
  checkBudgets(options, results, t);
  return t;
}

// quality.json: the settings, every scene's results and montage4d's
// verdict against holoportation, and the budget's checks.
nlohmann::json qualityJson(const EvalOptions& options, const std::vector<SceneResult>& results,
                           const QualityTables& tables) {
  nlohmann::json json;
  json["settings"] = {
      {"frames", options.frames},
      {"first_frame", options.first_frame},
      {"size", std::to_string(options.width) + "x" + std::to_string(options.height)},
      {"scene_fps", options.fps},
      {"held_out_cameras", options.held_out_cameras},
      {"geometry", options.geometry},
      {"voxel_size", options.loop.fusion.hull.voxel_size},
      {"hull_error_target_mm", 1000.0 * options.loop.fusion.hull_error_target},
      {"refine_voxels", options.loop.fusion.refine.depth_voxels},
      {"crop_margin", options.loop.pods.crop_margin},
      {"hull_without_held_out", options.hull_without_held_out},
      {"metrics",
       "RMSE and PSNR over RGB inside the true mask; SSIM on luminance (Wang 2004, "
       "11x11 Gaussian sigma 1.5, K1 0.01, K2 0.03), mean over windows centred in the mask; "
       "flicker: mean |change of the error image| between frames, grey levels (null: no two frames "
       "compared); "
       "seam_visibility: RMS gradient of the luminance error image over the pixels seam "
       "triangles cover, grey levels per pixel"}};
  for (const auto& scene : results) {
    nlohmann::json& s = json["scenes"][scene.name];
    s = sceneResultJson(scene);
    const Verdict v = montageVerdict(scene);
    s["montage4d_against_holoportation"] = {
        {"psnr_gain_db", v.psnr_gain_db},
        {"ssim_gain", v.ssim_gain},
        {"flicker_ratio", measuredJson(v.flicker_ratio)},
        {"target_met", v.met},
        {"short_of", v.why},
        {"is_a_target",
         scene.name != "clean" && scene.novel_view_degrees == 0 && !scene.camera_kept}};
    if (v.agreement.measured) {
      s["montage4d_against_holoportation"]["pictures"] = s["montage_agreement"];
    }
  }
  if (!options.budget.empty()) {
    json["budget_ms"] = options.budget;
    json["budget_unchecked"] = tables.unchecked_stages;
    json["budget_violations"] = tables.violations;
  }
  return json;
}

// quality.md: paper 000 Table 2's layout (per scene, per mode RMSE, PSNR,
// SSIM and rate), then flicker and seams, which it does not measure, and
// the rest of the tables.
std::string qualityMarkdown(const EvalOptions& options, const QualityTables& t) {
  std::ostringstream md;
  md << "# Leave-one-camera-out quality\n\n"
     << "Geometry: " << (options.geometry == "truth" ? "the true surface" : "the visual hull")
     << ". " << options.frames << " frames per scene from frame " << options.first_frame << ", "
     << options.width << "x" << options.height
     << "; each camera rendered from its reported pose without its own image"
     << (options.hull_without_held_out ? " and with a hull carved without its silhouette" : "")
     << ", compared with its "
        "true image inside its true mask (rows \"(camera kept)\": with its own image; \"+D deg\": "
        "novel poses, every "
        "camera blended).\n\n";
  md << html::markdownTable(t.rates);
  md << "\nfps: one render after a new mesh (field passes included), this machine's Vulkan device; "
        "paper 000's is "
        "the average over every frame.\n\n## Flicker and seams\n\n";
  md << html::markdownTable(t.flicker);
  md << "\nflicker: mean frame-to-frame change of the error image, grey levels (n/a: no two frames "
        "compared). seams: "
        "seam visibility, the RMS gradient of the luminance error along the pixels seam triangles "
        "cover (grey levels "
        "per pixel; lower is less visible; n/a: no seam in view).\n\n## Client link and server "
        "layers\n\n";
  md << html::markdownTable(t.layers);
  md << "\nKB/frame: what a client of the mode receives per frame (mesh, images or texture layers, "
        "stats); of it, mesh KB the mesh, layer colour KB the layers' colour (video or LZ4) and "
        "camera planes KB which camera each texel came from. charts moved: the share of the "
        "atlas's charts a video coder cannot predict in place from the frame before (new, in "
        "another slot, or shifted by half a texel or more), mean over frames. layers ms: the "
        "server's layer stage (layout, layers, LZ4), median; video ms: its "
        "video coding of the layers' colour (--layer-video), median; `-`: not in this mode.\n\n";
  md << "## Where the errors differ\n\nPSNR per region over every image (the squared error "
        "pooled), and the share of "
        "the squared-error difference from normal that each region carries (the shares sum to "
        "100%; a negative "
        "one goes against the whole picture's difference); the row \"pixels\" gives each region's "
        "share of the "
        "compared pixels. Regions: within 3 px of the true mask's edge (border), of a depth jump "
        "of the "
        "mesh seen from the pose (occlusion), on seam triangles (seam), elsewhere; pictures with "
        "--save-images "
        "(*_error.png, *_regions.png; float maps *_error.exr and, in the field modes, "
        "*_weights.exr).\n\n";
  md << html::markdownTable(t.regions);
  md << "\n## Geometry\n\nThe surface the client received against the truth (first frame; Chamfer "
        "from each mesh's "
        "vertices to the other's triangles, truth by marching cubes at 1 cm; IoU of its silhouette "
        "in each true mask; "
        "silhouette error: mean distance between its outline and each segmented mask's, what the "
        "voxel controls and "
        "`--hull-error-mm` targets).\n\n";
  md << html::markdownTable(t.geometry);
  if (!t.segmentation.rows.empty()) {
    md << "\n## Segmentation\n\nThe pods' masks against the true masks (each camera's worst "
          "frame; the mean over cameras and the worst camera), then the same masks cut to "
          "where the other cameras' hull projects (the rig's agreement, as import applies it), "
          "and of the subject's true shadow on the floor, the share the pods' masks took for "
          "the subject.\n\n"
       << html::markdownTable(t.segmentation);
  }
  md << "\n## Links and codecs\n\nBytes per frame as the loop sends them (the pods' rectangles "
        "with their "
        "feather maps; the server's Draco mesh and images to one client), and the codecs' ms per "
        "frame: "
     << kCodecsMeaning << ". " << kNoJitterHere << "\n\n";
  md << html::markdownTable(t.links);
  if (!t.verdicts.rows.empty()) {
    md << "\n## montage4d against holoportation\n\nTarget on every scene but clean: at least "
          "+0.5 dB PSNR, higher SSIM, and less flicker after a viewpoint jump. "
       << kPicturesDifferMeaning << "\n\n"
       << html::markdownTable(t.verdicts);
  }
  md << "\n## Time per stage of a new mesh (paper 000 Table 3 layout)\n\nGPU ms per field pass "
        "(timestamps, medians; "
        "on a CPU device such as lavapipe the boundaries are approximate), then the wall clock of "
        "the whole render "
        "after a new mesh. `-`: the mode runs no such pass.\n";
  for (const auto& [name, table] : t.stages)
    md << "\n" << name << "\n\n" << html::markdownTable(table);
  if (!options.budget.empty()) {
    md << "\n## Budget\n\np95 against the budget of each stage the evaluation times as the loop "
          "does ("
       << budgetedStagesText() << ")." << t.unchecked_text
       << (t.violations.empty() ? " Nothing is over budget.\n" : "\n\n");
    html::Table over{{"Scene", "mode", "stage", "p95 ms", "budget ms"}, {}, "lll"};
    for (const auto& row : t.budget_rows) {
      if (row[0][0] == '!') over.rows.push_back(row);
    }
    if (!over.rows.empty()) md << html::markdownTable(over);
  }
  return md.str();
}

// One bar series per mode of a ModeResult measure, a bar per scene.
std::vector<html::Series> modeSeries(const std::vector<SceneResult>& results,
                                     const std::vector<std::string>& modes,
                                     double ModeResult::*field) {
  std::vector<html::Series> series;
  for (const auto& mode : modes) {
    html::Series s{mode, {}};
    for (const auto& scene : results) {
      const auto it = scene.modes.find(mode);
      // Negative means not measured (no seam in view, no frame pair):
      // drawn as "n/a", not as a 0 that would look best.
      const double value = it == scene.modes.end() ? -1.0 : it->second.*field;
      s.values.push_back(value < 0 ? std::nan("") : value);
    }
    series.push_back(std::move(s));
  }
  return series;
}

// The charts of every scene by mode, and the table of all their numbers.
std::string qualityCharts(const std::vector<SceneResult>& results,
                          const std::vector<std::string>& modes) {
  std::vector<std::string> scene_names;
  for (const auto& scene : results) scene_names.push_back(scene.name);
  auto metric = [&](double ModeResult::*field) { return modeSeries(results, modes, field); };
  Rows rows;
  for (const auto& scene : results) {
    for (const auto& mode : modes) {
      const auto it = scene.modes.find(mode);
      if (it == scene.modes.end()) continue;
      const ModeResult& m = it->second;
      rows.push_back({scene.name, mode, html::number("%.2f%%", m.rmse_percent),
                      html::number("%.2f dB", m.psnr_db), html::number("%.4f", m.ssim),
                      measuredText(m.flicker, "%.2f"), measuredText(m.seam_visibility, "%.2f"),
                      html::number("%.1f", m.ms_per_new_mesh), std::to_string(m.images)});
    }
  }
  std::string body;
  body += html::barChart("PSNR by scene", scene_names, metric(&ModeResult::psnr_db), "dB");
  body +=
      html::barChart("SSIM by scene", scene_names, metric(&ModeResult::ssim), "luminance, masked");
  body += html::barChart("Flicker by scene", scene_names, metric(&ModeResult::flicker),
                         "grey levels per frame");
  body +=
      html::barChart("Seam visibility by scene", scene_names, metric(&ModeResult::seam_visibility),
                     "RMS error gradient along seams, grey levels per pixel");
  body += html::barChart("Client time per new mesh", scene_names,
                         metric(&ModeResult::ms_per_new_mesh), "ms");
  body +=
      "<h2>All numbers</h2>\n" + html::table({"scene", "mode", "RMSE", "PSNR", "SSIM", "flicker",
                                              "seam visibility", "ms per new mesh", "images"},
                                             rows);
  return body;
}

// The latency budget of a new mesh per scene: the server's hull, the
// codecs on the frame's way, and each mode's render, p50 and p95 over
// the frames (transport is not simulated).
std::string latencyCharts(const std::vector<SceneResult>& results,
                          const std::vector<std::string>& modes) {
  std::string body =
      "<h2>Latency of a new mesh by stage</h2>\n<p>Each stage's p50 over the renders: the hull, "
      "the codecs by stage (" +
      std::string(kCodecsMeaning) +
      ") and the client's render; their p95s, which do not add up, are in the tables. "
      "Transport is not simulated.</p>\n";
  for (const auto& scene : results) {
    if (!ownRenders(scene)) continue;
    std::vector<html::StackRow> stack;
    for (const auto& mode : modes) {
      const auto it = scene.modes.find(mode);
      if (it == scene.modes.end()) continue;
      stack.push_back({mode, latencyParts(scene, it->second, false), std::nullopt, ""});
    }
    body += html::stackedBars("Latency of a new mesh: " + scene.name + " (each stage's p50)",
                              latencyStages(), stack, "ms");
  }
  return body;
}

// quality.html: the same for people, with charts.
std::string qualityHtml(const EvalOptions& options, const std::vector<SceneResult>& results,
                        const QualityTables& t) {
  std::string body =
      "<p>" +
      html::escape(
          std::to_string(options.frames) + " frames per scene from frame " +
          std::to_string(options.first_frame) + ", " + std::to_string(options.width) + "x" +
          std::to_string(options.height) +
          "; each camera rendered from its reported pose without its own image, "
          "compared with its true image inside its true mask (rows \"(camera kept)\": with its own "
          "image; \"+D deg\": novel poses, every camera blended).") +
      "</p>\n";
  body += qualityCharts(results, t.modes);
  body +=
      "<h2>Links and codecs</h2>\n<p>Bytes per frame as the loop sends them, and the codecs' ms "
      "per frame: " +
      html::escape(kCodecsMeaning) + ". " + html::escape(kNoJitterHere) + "</p>\n" +
      html::table(t.links);
  // Only where both modes ran: an empty table reads as a result.
  if (!t.verdicts.rows.empty()) {
    body +=
        "<h2>montage4d against holoportation</h2>\n<p>Target on every scene but clean: at least "
        "+0.5 dB PSNR, higher SSIM, and less flicker after a viewpoint jump. Misses are flagged. " +
        html::escape(kPicturesDifferMeaning) + "</p>\n" + html::table(t.verdicts);
  }
  if (!t.budget_rows.empty() || !options.budget.empty()) {
    body +=
        "<h2>Budget</h2>\n<p>p95 against the budget of each stage the evaluation times as the loop "
        "does "
        "(" +
        budgetedStagesText() + "); over-budget rows are flagged." + html::escape(t.unchecked_text) +
        "</p>\n" + html::table({"scene", "mode", "stage", "p95 ms", "budget ms"}, t.budget_rows);
  }
  body += latencyCharts(results, t.modes);
  body +=
      "<h2>Time per stage of a new mesh (paper 000 Table 3 layout)</h2>\n<p>GPU ms per field pass "
      "(timestamps, "
      "medians; approximate on a CPU device), then the wall clock of the render after a new "
      "mesh.</p>\n";
  for (const auto& [name, table] : t.stages)
    body += "<h3>" + html::escape(name) + "</h3>\n" + html::table(table);
  return html::page("holofuse leave-one-camera-out quality", body);
}

}  // namespace

Status writeQualityReports(const EvalOptions& options, const std::vector<SceneResult>& results,
                           const std::string& out_dir) {
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) return Status(StatusCode::kIoError, out_dir + ": " + ec.message());
  const QualityTables tables = qualityTables(options, results);
  const fs::path dir(out_dir);
  HOLOFUSE_RETURN_IF_ERROR(
      writeTextFile((dir / "quality.md").string(), qualityMarkdown(options, tables)));
  HOLOFUSE_RETURN_IF_ERROR(writeTextFile((dir / "quality.json").string(),
                                         qualityJson(options, results, tables).dump(2) + "\n"));
  return writeTextFile((dir / "quality.html").string(), qualityHtml(options, results, tables));
}

}  // namespace holofuse::eval
