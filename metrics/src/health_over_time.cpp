#include "metrics/health_over_time.h"

#include <algorithm>
#include <cstdio>

namespace holofuse {

double medianOf(std::vector<double> values) {
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return v < 0; }),
               values.end());
  if (values.empty()) return -1;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

std::vector<bool> belowTheFramesMedian(const std::vector<double>& values) {
  const double median = medianOf(values);
  std::vector<bool> apart(values.size(), false);
  for (size_t c = 0; c < values.size(); ++c)
    apart[c] = median >= 0 && values[c] >= 0 && values[c] < median - kHealthGap;
  return apart;
}

HealthOverTime summariseHealthOverTime(const std::vector<uint64_t>& frame_ids,
                                       const std::vector<std::vector<double>>& values,
                                       const std::vector<std::vector<bool>>& set_apart) {
  HealthOverTime health;
  health.frame_ids = frame_ids;
  const size_t cameras = values.empty() ? 0 : values.front().size();
  health.cameras.resize(cameras);
  std::vector<double> medians;
  for (size_t c = 0; c < cameras; ++c) {
    HealthOverTime::Camera& camera = health.cameras[c];
    for (size_t k = 0; k < values.size(); ++k) {
      camera.agreement.push_back(c < values[k].size() ? values[k][c] : -1.0);
      if (k < set_apart.size() && c < set_apart[k].size() && set_apart[k][c])
        camera.bad_frames.push_back(frame_ids[k]);
    }
    camera.median = medianOf(camera.agreement);
    for (double v : camera.agreement)
      if (v >= 0) camera.min = camera.min < 0 ? v : std::min(camera.min, v);
    medians.push_back(camera.median);
  }
  const double rig_median = medianOf(medians);
  char text[240];
  for (HealthOverTime::Camera& camera : health.cameras) {
    std::string frames;
    for (size_t k = 0; k < camera.bad_frames.size() && k < 8; ++k)
      frames += (k ? ", " : "") + std::to_string(camera.bad_frames[k]);
    if (camera.bad_frames.size() > 8)
      frames += " and " + std::to_string(camera.bad_frames.size() - 8) + " more";
    if (camera.median >= 0 && camera.median < rig_median - kHealthGap) {
      std::snprintf(
          text, sizeof(text),
          "over the frames measured its masks agree with the hull at a median IoU of %.2f, "
          "where the cameras' median is %.2f",
          camera.median, rig_median);
      camera.concern = text;
      if (!frames.empty()) camera.concern += "; set apart in frames " + frames;
    } else if (!camera.bad_frames.empty()) {
      std::snprintf(text, sizeof(text),
                    "its mask is set apart from the rest in %zu of the %zu frames measured (IoU "
                    "with the hull down to %.2f, median %.2f): frames ",
                    camera.bad_frames.size(), values.size(), camera.min, camera.median);
      camera.concern = text + frames;
    }
  }
  return health;
}

}  // namespace holofuse
