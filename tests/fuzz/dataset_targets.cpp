// Fuzz targets of what holofuse reads from disk: the dataset container
// (protocol/SPEC.md section 7) as replay and eval open it, and every
// capture format's reader as `holofuse dataset import` runs it. Files are
// written where the readers expect them (a memory file for the container,
// a scratch folder under the temporary directory for captures).
#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <fstream>

#include "dataset/dataset.h"
#include "fuzz_capture.h"
#include "fuzz_target.h"

namespace holofuse::fuzz {
namespace {

namespace fs = std::filesystem;

// A file in memory with a path the readers can open.
class MemoryFile {
 public:
  MemoryFile() : fd_(::memfd_create("holofuse-fuzz", MFD_CLOEXEC)) {
    require(fd_ >= 0, "memfd_create works (Linux 3.17 and later)");
  }
  ~MemoryFile() { ::close(fd_); }
  std::string hold(const uint8_t* data, size_t size) {
    require(::ftruncate(fd_, 0) == 0, "a memory file truncates");
    for (size_t written = 0; written < size;) {
      const ssize_t n = ::pwrite(fd_, data + written, size - written, static_cast<off_t>(written));
      require(n > 0, "a memory file takes every byte");
      written += static_cast<size_t>(n);
    }
    return "/proc/self/fd/" + std::to_string(fd_);
  }

 private:
  int fd_;
};

bool finite(const Camera& c) {
  for (double v :
       {c.fx, c.fy, c.cx, c.cy, c.skew, c.translation.x, c.translation.y, c.translation.z})
    if (!std::isfinite(v)) return false;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (!std::isfinite(c.rotation[i][j])) return false;
  return true;
}

// One scratch folder per capture target and process, with the rig's
// images in it, made on first use and removed when the process exits.
class ScratchFolders {
 public:
  ~ScratchFolders() {
    std::error_code ignored;
    for (const auto& [target, root] : roots_) fs::remove_all(root, ignored);
  }
  const fs::path& of(const CaptureTarget& target) {
    auto [it, made] = roots_.try_emplace(target.target);
    if (made) {
      it->second = fs::temp_directory_path() /
                   ("holofuse_fuzz_" + std::to_string(::getpid()) + "_" + target.target);
      fs::create_directories(it->second);
      require(writeCaptureImages(it->second).isOk(), "the rig's images are written");
    }
    return it->second;
  }

 private:
  std::map<std::string, fs::path> roots_;
};

int readCaptureFiles(const CaptureTarget& target, const uint8_t* data, size_t size) {
  static ScratchFolders scratch;
  const fs::path& root = scratch.of(target);
  const auto parts = splitFiles({reinterpret_cast<const char*>(data), size}, target.files.size());
  for (size_t i = 0; i < target.files.size(); ++i) {
    if (i < parts.size()) {
      std::ofstream(root / target.files[i], std::ios::binary | std::ios::trunc)
          .write(parts[i].data(), static_cast<std::streamsize>(parts[i].size()));
    } else {
      fs::remove(root / target.files[i]);
    }
  }
  auto capture = dataset::readCapture(root.string(), target.format);
  if (!capture.isOk()) return 0;
  ++accepted()[target.target];
  require(!capture->cameras.empty(), "an accepted capture has cameras");
  for (const dataset::CaptureCamera& cam : capture->cameras) {
    const Camera& c = cam.camera;
    require(c.width >= 1 && c.width <= 16384 && c.height >= 1 && c.height <= 16384,
            "every camera's image size is in 1..16384");
    require(finite(c) && c.fx > 0 && c.fy > 0, "finite intrinsics and positive focal lengths");
    require(std::abs(glm::determinant(c.rotation) - 1.0) < 1e-3, "R is a rotation");
  }
  for (const dataset::CaptureFrame& frame : capture->frames) {
    require(frame.images.size() == capture->cameras.size() &&
                frame.masks.size() == capture->cameras.size(),
            "every frame names an image and a mask slot for every camera");
  }
  return 0;
}

const CaptureTarget& captureTarget(const char* name) {
  for (const CaptureTarget& t : captureTargets())
    if (std::string(t.target) == name) return t;
  require(false, "every import target is in captureTargets()");
  std::abort();
}

}  // namespace

// A recording as replay and eval open it: the container's header, index
// or scan, every record's CRCs, the dataset's metadata, each camera's
// calibration and frames, and each frame's planes against its camera.
HOLOFUSE_FUZZ_TARGET(dataset_container) {
  static MemoryFile file;
  auto dataset = dataset::Dataset::open(file.hold(data, size));
  if (!dataset.isOk()) return 0;
  ++accepted()["dataset_container"];
  (void)dataset->records().verifyAll();
  for (const auto& [id, camera] : dataset->cameras()) {
    require(camera.id == id, "a camera is filed under its own id");
    auto calibration = dataset->readCalibration(id);
    if (!calibration.isOk()) continue;
    const Camera c = fromCalibration(*calibration);
    for (const dataset::RecordInfo& record : camera.frames) {
      auto frame = dataset->readFrame(record);
      if (!frame.isOk()) continue;
      auto images = dataset::decodePodImages(*frame, c);
      if (!images.isOk()) continue;
      require(images->color.width == c.width && images->color.height == c.height &&
                  images->mask.width == c.width && images->mask.height == c.height,
              "a recorded frame's planes come back as its camera's whole image");
    }
  }
  return 0;
}

// One target per capture format, each reading the files captureTargets()
// names for it.
#define HOLOFUSE_CAPTURE_FUZZ_TARGET(name) \
  HOLOFUSE_FUZZ_TARGET(name) { return readCaptureFiles(captureTarget(#name), data, size); }

HOLOFUSE_CAPTURE_FUZZ_TARGET(import_holofuse)
HOLOFUSE_CAPTURE_FUZZ_TARGET(import_colmap_text)
HOLOFUSE_CAPTURE_FUZZ_TARGET(import_colmap_binary)
HOLOFUSE_CAPTURE_FUZZ_TARGET(import_nerf)
HOLOFUSE_CAPTURE_FUZZ_TARGET(import_opencv)
HOLOFUSE_CAPTURE_FUZZ_TARGET(import_projections)
HOLOFUSE_CAPTURE_FUZZ_TARGET(import_middlebury)
HOLOFUSE_CAPTURE_FUZZ_TARGET(import_panoptic)

}  // namespace holofuse::fuzz
