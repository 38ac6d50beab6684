#include "dataset/camera_health.h"

#include <algorithm>
#include <cstdio>

#include "metrics/geometry_metrics.h"

namespace holofuse::dataset {

std::vector<CameraHealth> cameraHealth(const std::vector<hull::HullView>& views,
                                       const hull::HullOptions& options) {
  std::vector<CameraHealth> health(views.size());
  std::vector<double> agreements, others_agreements;
  for (size_t j = 0; j < views.size(); ++j) {
    const Image8& mask = views[j].mask;
    size_t inside = 0;
    for (const uint8_t v : mask.pixels) inside += v != 0;
    health[j].coverage =
        mask.pixels.empty() ? 0.0 : static_cast<double>(inside) / mask.pixels.size();
    // Two others carve a hull that says something about a third.
    if (views.size() < 3) continue;
    std::vector<hull::HullView> others = views;
    others.erase(others.begin() + static_cast<std::ptrdiff_t>(j));
    const Mesh hull = hull::carveVisualHull(others, options);
    health[j].agreement = metrics::silhouetteIoU(hull, views[j].camera, mask);
    double sum = 0;
    for (const hull::HullView& other : others)
      sum += metrics::silhouetteIoU(hull, other.camera, other.mask);
    health[j].others_agreement = sum / static_cast<double>(others.size());
    agreements.push_back(health[j].agreement);
    others_agreements.push_back(health[j].others_agreement);
  }
  const double agreement_median = medianOf(agreements);
  const double others_median = medianOf(others_agreements);
  char text[200];
  for (CameraHealth& h : health) {
    if (h.coverage == 0) {
      h.concern = "its mask is empty";
    } else if (h.coverage >= kFullFrameCoverage) {
      std::snprintf(text, sizeof(text), "its mask covers %.0f%% of the frame, so it carves nothing",
                    100 * h.coverage);
      h.concern = text;
    } else if (h.others_agreement >= 0 && h.others_agreement > others_median + kAgreementGap) {
      std::snprintf(text, sizeof(text),
                    "it carves away what the others see: without it their masks agree with the "
                    "hull at IoU %.2f, where the median is %.2f",
                    h.others_agreement, others_median);
      h.concern = text;
    } else if (h.agreement >= 0 && h.agreement < agreement_median - kAgreementGap) {
      std::snprintf(text, sizeof(text),
                    "its mask agrees with the hull of the other cameras at IoU %.2f, where the "
                    "cameras' median is %.2f",
                    h.agreement, agreement_median);
      h.concern = text;
    }
  }
  return health;
}

HealthOverTime summariseHealthOverTime(const std::vector<uint64_t>& frame_ids,
                                       const std::vector<std::vector<CameraHealth>>& per_frame) {
  std::vector<std::vector<double>> values;
  std::vector<std::vector<bool>> set_apart;
  for (const auto& frame : per_frame) {
    values.emplace_back();
    set_apart.emplace_back();
    for (const CameraHealth& h : frame) {
      values.back().push_back(h.agreement);
      set_apart.back().push_back(!h.concern.empty());
    }
  }
  return holofuse::summariseHealthOverTime(frame_ids, values, set_apart);
}

std::string healthOverTimeText(const std::vector<std::string>& names, const HealthOverTime& health,
                               size_t frames_in_dataset) {
  if (health.frame_ids.empty() || health.cameras.empty()) return "";
  char line[200];
  std::snprintf(line, sizeof(line),
                "mask health over time: %zu of %zu frames (ids %llu to %llu), each camera's mask "
                "against the other cameras' hull (IoU)\n",
                health.frame_ids.size(), frames_in_dataset,
                static_cast<unsigned long long>(health.frame_ids.front()),
                static_cast<unsigned long long>(health.frame_ids.back()));
  std::string t = line;
  t += "camera                   min   median  frames set apart\n";
  std::string concerns;
  for (size_t i = 0; i < health.cameras.size(); ++i) {
    const HealthOverTime::Camera& c = health.cameras[i];
    const std::string name = i < names.size() ? names[i] : std::to_string(i);
    if (c.median < 0) {
      std::snprintf(line, sizeof(line), "%-4zu %-16s   n/a (fewer than 3 cameras)\n", i,
                    name.c_str());
    } else {
      std::snprintf(line, sizeof(line), "%-4zu %-16s %6.3f %7.3f  %zu%s\n", i, name.c_str(), c.min,
                    c.median, c.bad_frames.size(), c.concern.empty() ? "" : "   <- CHECK");
    }
    t += line;
    if (!c.concern.empty())
      concerns += "CHECK camera " + std::to_string(i) + " \"" + name + "\": " + c.concern + "\n";
  }
  return t + concerns;
}

std::string cameraHealthText(const std::vector<std::string>& names,
                             const std::vector<CameraHealth>& health,
                             const std::string& inspect_command) {
  std::string t = "camera                mask covers  agrees with the others' hull (IoU)\n";
  std::string concerns;
  for (size_t i = 0; i < health.size(); ++i) {
    const std::string name = i < names.size() ? names[i] : std::to_string(i);
    char line[160];
    char agreement[32] = "n/a";
    if (health[i].agreement >= 0)
      std::snprintf(agreement, sizeof(agreement), "%.3f", health[i].agreement);
    std::snprintf(line, sizeof(line), "%-4zu %-16s %10.1f%%  %s%s\n", i, name.c_str(),
                  100 * health[i].coverage, agreement,
                  health[i].concern.empty() ? "" : "   <- CHECK");
    t += line;
    if (!health[i].concern.empty()) {
      concerns += "CHECK camera " + std::to_string(i) + " \"" + name + "\": " + health[i].concern +
                  ". Look at it: " + inspect_command +
                  " (its tile is marked); leave it out: import again with --exclude-cameras " +
                  name + "\n";
    }
  }
  return t + concerns;
}

}  // namespace holofuse::dataset
