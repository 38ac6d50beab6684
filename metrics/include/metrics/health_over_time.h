// Each camera's mask health over a video: per camera a value per frame
// measured (its mask's IoU with a hull), its min and median, and the frames
// where it was set apart from the rest. `dataset info` fills it from the
// cameras' health frame by frame, the render client's report from the
// hull it receives.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace holofuse {

struct HealthOverTime {
  std::vector<uint64_t> frame_ids;  // the frames measured, in order
  struct Camera {
    std::vector<double> agreement;  // per measured frame; negative: not measured
    double min = -1, median = -1;
    std::vector<uint64_t> bad_frames;  // frames where it was set apart from the rest
    std::string concern;               // empty, or what sets it apart over time
  };
  std::vector<Camera> cameras;
};

// A camera's agreement this far below the cameras' median sets it apart.
inline constexpr double kHealthGap = 0.25;

// Per frame k (frame_ids[k]), one value per camera (negative: not
// measured) and whether the camera was set apart then. Fills each camera's
// min, median and bad frames, and its concern: a median kHealthGap below
// the cameras' median of medians, or any bad frame (both name up to eight
// frames).
HealthOverTime summariseHealthOverTime(const std::vector<uint64_t>& frame_ids,
                                       const std::vector<std::vector<double>>& values,
                                       const std::vector<std::vector<bool>>& set_apart);

// Set apart in one frame: under the frame's median over the cameras by
// kHealthGap or more.
std::vector<bool> belowTheFramesMedian(const std::vector<double>& values);

// The median of the non-negative values; -1 when there is none.
double medianOf(std::vector<double> values);

}  // namespace holofuse
