// What the evaluation concludes from its numbers: the error regions of a
// comparison, each mode's share of the error by region against normal,
// the budget checks, and montage4d's verdict against its targets.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "eval/leave_one_out.h"
#include "render_client/reference/visibility.h"

namespace holofuse::eval {

using metrics::ErrorRegion;
using metrics::errorRegionName;
using metrics::kErrorRegionCount;
using metrics::kOutsideRegions;

Image8 errorRegions(const Image8& mask, const DepthMap& depth, const Image8& seams, int reach_px,
                    double relative_jump) {
  const uint32_t w = mask.width, h = mask.height;
  if (mask.channels != 1 || seams.width != w || seams.height != h || seams.channels != 1 ||
      depth.width != w || depth.height != h) {
    throw std::invalid_argument(
        "errorRegions: mask, depth and seams must be one-channel images of one size");
  }
  const size_t n = static_cast<size_t>(w) * h;
  // The mask as a depth map: its outline is the mask's inside pixels next
  // to the background, so that grown by reach_px - 1 it holds the pixels
  // within reach_px of the background.
  DepthMap silhouette{w, h, std::vector<double>(n, kNoDepth)};
  for (size_t p = 0; p < n; ++p) {
    if (mask.pixels[p] != 0) silhouette.depth[p] = 1.0;
  }
  const auto near_outside = render::reference::dilatedDiscontinuities(
      silhouette, {std::max(0, reach_px - 1), relative_jump});
  const auto near_jump =
      render::reference::dilatedDiscontinuities(depth, {std::max(0, reach_px), relative_jump});
  Image8 regions(w, h, 1, kOutsideRegions);
  for (size_t p = 0; p < n; ++p) {
    if (mask.pixels[p] == 0) continue;
    ErrorRegion r = ErrorRegion::kElsewhere;
    if (near_outside[p]) {
      r = ErrorRegion::kSilhouetteBorder;
    } else if (near_jump[p]) {
      r = ErrorRegion::kOcclusionEdge;
    } else if (seams.pixels[p] != 0) {
      r = ErrorRegion::kSeam;
    }
    regions.pixels[p] = static_cast<uint8_t>(r);
  }
  return regions;
}

std::map<std::string, double> regionSharesAgainstNormal(
    const std::map<std::string, ModeResult>& modes, const std::string& mode) {
  const auto normal = modes.find(render::blendModeName(render::BlendMode::kNormal));
  const auto other = modes.find(mode);
  std::map<std::string, double> shares;
  if (normal == modes.end() || other == modes.end() || normal == other) return shares;
  std::array<double, kErrorRegionCount> difference{};
  double total = 0, scale = 0;
  for (size_t r = 0; r < kErrorRegionCount; ++r) {
    difference[r] =
        normal->second.regions.squared_error[r] - other->second.regions.squared_error[r];
    total += difference[r];
    scale += normal->second.regions.squared_error[r];
  }
  if (!(std::abs(total) > 1e-9 * std::max(scale, 1.0))) return shares;
  for (size_t r = 0; r < kErrorRegionCount; ++r) {
    shares[errorRegionName(static_cast<ErrorRegion>(r))] = difference[r] / total;
  }
  return shares;
}

std::vector<BudgetCheck> checkBudget(const protocol::Budget& budget, const SceneResult& scene,
                                     const std::vector<std::string>& modes) {
  std::vector<BudgetCheck> checks;
  auto check = [&](const std::string& mode, const std::string& stage, double p95) {
    const auto it = budget.find(stage);
    if (it != budget.end()) checks.push_back({mode, stage, p95, it->second});
  };
  check("-", "hull", scene.hull_ms_p95);
  check("-", "refine", scene.refine_ms_p95);
  for (const auto& [stage, p95] : scene.codec_stage_ms_p95) check("-", stage, p95);
  for (const auto& mode : modes) {
    const auto it = scene.modes.find(mode);
    if (it != scene.modes.end()) check(mode, "render", it->second.ms_per_new_mesh_p95);
  }
  return checks;
}

std::string measuredText(double value, const char* format) {
  if (value < 0) return "n/a";
  char text[32];
  std::snprintf(text, sizeof(text), format, value);
  return text;
}

Verdict montageVerdict(const SceneResult& scene) {
  Verdict v;
  const auto holo = scene.modes.find("holoportation"), montage = scene.modes.find("montage4d");
  if (holo == scene.modes.end() || montage == scene.modes.end()) {
    v.why = "needs both holoportation and montage4d";
    return v;
  }
  v.psnr_gain_db = montage->second.psnr_db - holo->second.psnr_db;
  v.ssim_gain = montage->second.ssim - holo->second.ssim;
  const double holo_flicker = holo->second.flicker, montage_flicker = montage->second.flicker;
  if (holo_flicker >= 0 && montage_flicker >= 0) {
    // Both steady (0 and 0) is a tie, not less flicker.
    v.flicker_ratio = holo_flicker > 0      ? montage_flicker / holo_flicker
                      : montage_flicker > 0 ? montage_flicker / 1e-6
                                            : 1.0;
  }
  v.agreement = scene.montage_agreement;
  std::vector<std::string> short_of;
  if (v.psnr_gain_db < 0.5) {
    std::string why = "PSNR gain below 0.5 dB";
    if (v.agreement.measured && v.agreement.gain_bound_db < 0.5) {
      char text[200];
      std::snprintf(text, sizeof(text),
                    " (montage4d changes too little of holoportation's picture: they differ on "
                    "%.0f%% of the pixels, "
                    "and exact on all of them it would gain %.2f dB)",
                    100 * v.agreement.differing_share, v.agreement.gain_bound_db);
      why += text;
    }
    short_of.push_back(why);
  }
  if (!(v.ssim_gain > 0)) short_of.push_back("SSIM not higher");
  if (scene.view_jump_degrees != 0 && v.flicker_ratio < 0) {
    // The jump comes halfway: three frames give one pair after it.
    short_of.push_back("flicker after the jump not measured (it needs --frames 3 or more)");
  } else if (scene.view_jump_degrees != 0 && !(v.flicker_ratio < 1.0)) {
    short_of.push_back("flickers no less after the jump");
  }
  v.met = short_of.empty();
  for (const auto& s : short_of) v.why += (v.why.empty() ? "" : "; ") + s;
  return v;
}

}  // namespace holofuse::eval
