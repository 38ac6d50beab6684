#include "dataset/camera_health.h"

#include <algorithm>
#include <cstdio>

#include "metrics/geometry_metrics.h"

namespace holofuse::dataset {

namespace {

double median(std::vector<double> values) {
  if (values.empty()) return -1;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

}  // namespace

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
  const double agreement_median = median(agreements);
  const double others_median = median(others_agreements);
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
  HealthOverTime health;
  health.frame_ids = frame_ids;
  const size_t cameras = per_frame.empty() ? 0 : per_frame.front().size();
  health.cameras.resize(cameras);
  std::vector<double> medians;
  for (size_t c = 0; c < cameras; ++c) {
    HealthOverTime::Camera& camera = health.cameras[c];
    std::vector<double> measured;
    for (size_t k = 0; k < per_frame.size(); ++k) {
      const CameraHealth* h = c < per_frame[k].size() ? &per_frame[k][c] : nullptr;
      camera.agreement.push_back(h ? h->agreement : -1.0);
      if (camera.agreement.back() >= 0) measured.push_back(camera.agreement.back());
      if (h && !h->concern.empty()) camera.bad_frames.push_back(frame_ids[k]);
    }
    if (measured.empty()) continue;
    camera.min = *std::min_element(measured.begin(), measured.end());
    camera.median = median(measured);
    medians.push_back(camera.median);
  }
  const double rig_median = median(medians);
  char text[240];
  for (HealthOverTime::Camera& camera : health.cameras) {
    std::string frames;
    for (size_t k = 0; k < camera.bad_frames.size() && k < 8; ++k)
      frames += (k ? ", " : "") + std::to_string(camera.bad_frames[k]);
    if (camera.bad_frames.size() > 8)
      frames += " and " + std::to_string(camera.bad_frames.size() - 8) + " more";
    if (camera.median >= 0 && camera.median < rig_median - kAgreementGap) {
      std::snprintf(text, sizeof(text),
                    "over the video its masks agree with the others' hull at a median IoU of "
                    "%.2f, where the cameras' median is %.2f",
                    camera.median, rig_median);
      camera.concern = text;
      if (!frames.empty()) camera.concern += "; set apart in frames " + frames;
    } else if (!camera.bad_frames.empty()) {
      std::snprintf(text, sizeof(text),
                    "its mask is set apart from the rest in %zu of the %zu frames measured "
                    "(IoU with the others' hull down to %.2f, median %.2f): frames ",
                    camera.bad_frames.size(), per_frame.size(), camera.min, camera.median);
      camera.concern = text + frames;
    }
  }
  return health;
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
