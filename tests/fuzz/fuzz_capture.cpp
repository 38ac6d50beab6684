#include "fuzz_capture.h"

#include "fuzz_rig.h"
#include "image/image_io.h"

namespace holofuse::fuzz {

namespace fs = std::filesystem;
using dataset::CaptureFormat;

const std::vector<CaptureTarget>& captureTargets() {
  static const std::vector<CaptureTarget> all = {
      {"import_holofuse", CaptureFormat::kHolofuse, {"capture.json"}},
      {"import_colmap_text", CaptureFormat::kColmap, {"cameras.txt", "images.txt"}},
      {"import_colmap_binary", CaptureFormat::kColmap, {"cameras.bin", "images.bin"}},
      {"import_nerf", CaptureFormat::kNerf, {"transforms.json"}},
      {"import_opencv", CaptureFormat::kOpencv, {"intri.yml", "extri.yml"}},
      {"import_projections",
       CaptureFormat::kProjections,
       {"cam0.pa", "cam1.pa", "cam2.pa", "cam3.pa"}},
      {"import_middlebury", CaptureFormat::kMiddlebury, {"rig_par.txt"}},
      {"import_panoptic", CaptureFormat::kPanoptic, {"calibration_rig.json"}},
  };
  return all;
}

std::vector<std::string_view> splitFiles(std::string_view input, size_t count) {
  std::vector<std::string_view> files;
  while (files.size() + 1 < count) {
    const size_t at = input.find(kNextFile);
    if (at == std::string_view::npos) break;
    files.push_back(input.substr(0, at));
    input.remove_prefix(at + kNextFile.size());
  }
  files.push_back(input);
  return files;
}

std::string joinFiles(const std::vector<std::string>& files) {
  std::string joined;
  for (size_t i = 0; i < files.size(); ++i) {
    if (i > 0) joined += kNextFile;
    joined += files[i];
  }
  return joined;
}

Status writeCaptureImages(const fs::path& root) {
  std::error_code error;
  for (int i = 0; i < kRigCameras; ++i) {
    const std::string name = kCaptureNames[i];
    Image8 image(kRigWidth, kRigHeight, 3, static_cast<uint8_t>(40 + 50 * i));
    for (const fs::path& file : {root / (name + ".png"), root / "images" / (name + ".png"),
                                 root / "hdImgs" / name / "000000.png"}) {
      fs::create_directories(file.parent_path(), error);
      Status written = writeImage(file.string(), image);
      if (!written.isOk()) return written;
    }
  }
  return Status::ok();
}

}  // namespace holofuse::fuzz
