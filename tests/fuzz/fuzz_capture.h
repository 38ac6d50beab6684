// What the import fuzz targets read and the seed generator writes: one
// target per capture format, the calibration files it fuzzes (a fuzzed
// input holds them back to back, split at kNextFile), and the rig's images
// laid out where every format looks for them, so a seed's calibration
// finds its images and the parser is fuzzed past its first checks.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "base/status.h"
#include "dataset/capture_formats.h"

namespace holofuse::fuzz {

struct CaptureTarget {
  const char* target;  // the fuzz target's name
  dataset::CaptureFormat format;
  std::vector<const char*> files;  // relative to the capture's folder, in input order
};

const std::vector<CaptureTarget>& captureTargets();

// Between two files of one input.
inline constexpr std::string_view kNextFile = "\n#%holofuse-fuzz-next-file%#\n";

std::vector<std::string_view> splitFiles(std::string_view input, size_t count);
std::string joinFiles(const std::vector<std::string>& files);

// The rig's camera names (camera i of fuzzRig() is kCaptureNames[i]).
inline constexpr const char* kCaptureNames[] = {"cam0", "cam1", "cam2", "cam3"};

// Each rig camera's image as <name>.png at the root and in images/, and as
// the one frame of hdImgs/<name>/ (Panoptic's layout).
Status writeCaptureImages(const std::filesystem::path& root);

}  // namespace holofuse::fuzz
