// Turns a real capture (CaptureDescription) into a holofuse dataset that
// replays like any recording: per camera a Calibration, per frame a
// PodFrame made the way a pod makes one (mask, feather map, foreground
// rectangle, LZ4), plus the dataset's metadata (capture volume, voxel size,
// camera names). Images are read (PNG, JPEG; grey, RGB or RGBA; 8 or 16
// bit) and undistorted to the pinhole model; masks are the source's, or
// segmented when missing. Everything is read and checked before a byte is
// written, and the dataset appears under its name only when complete.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "base/status.h"
#include "dataset/camera_health.h"
#include "dataset/capture_formats.h"
#include "image/image.h"

namespace holofuse::dataset {

struct ImportOptions {
  // Segmentation when a camera has no mask: background subtraction against
  // its plate when there is one, else a threshold on brightness (the
  // largest of R, G, B over 255): `threshold` in (0, 1), or Otsu's when
  // unset; dark_subject flips it for a dark subject on a light background.
  std::optional<double> threshold;
  bool dark_subject = false;
  int close_px = 5;                  // morphological closing radius after thresholding
  std::optional<double> voxel_size;  // default: the capture volume's longest side / 96
  int crop_margin = 8;               // as pods send: the foreground rectangle grown by this
  // A mask pixel is the subject where its brightest colour channel (or
  // grey level, or an RGBA image's alpha) is above this share of its full
  // range: masks saved through a video or JPEG step carry faint noise in
  // the background and soft edges. Specks of subject far smaller than the
  // subject are then dropped.
  double mask_threshold = 0.5;
  // Cameras left out, by their names in the source.
  std::vector<std::string> exclude_cameras;
  // With three cameras or more, each segmented mask is cut to where the
  // other cameras' hull projects (hull/mask_agreement.h): what no other
  // camera sees inside the capture volume is not the subject.
  bool rig_agreement = true;
};

struct ImportProgress {
  size_t done = 0, total = 0;  // images
  double megabytes = 0;
  double seconds = 0;
};

struct ImportSummary {
  size_t cameras = 0, frames = 0;
  double megabytes = 0;
  size_t masks_given = 0, masks_segmented = 0;
  std::string volume;  // "min (x, y, z) max (x, y, z), voxel v"
  // The first frame's masks against each other (camera_health.h), per
  // camera in pod id order, with the cameras' names.
  std::vector<std::string> camera_names;
  std::vector<CameraHealth> health;
  // What a person should look at before trusting the dataset: a camera
  // whose first mask is empty or nearly its whole picture, by name.
  std::vector<std::string> warnings;
  // Per camera, what the rig's agreement cut from its segmented masks:
  // pixels, and in how many frames.
  std::vector<uint64_t> agreement_pixels_cut;
  std::vector<size_t> agreement_frames_cut;
  std::vector<uint64_t> segmented_pixels;  // the segmenter's mask pixels before the cut
  // Per camera, how far the others' hull had to move to overlap its first
  // segmented mask best (pixels): the calibrations' disagreement there.
  std::vector<std::pair<int, int>> agreement_shift;
};

// What the rig's agreement did, for people: a line per camera whose mask
// it moved the others' hull 3 px or more to meet (their calibrations
// disagree), and per camera it cut 0.1% of the segmented pixels or more
// from; empty otherwise.
std::string agreementText(const ImportSummary& summary);

// Brightness threshold segmentation with clean-up (open 1 px, close
// close_px, largest connected component, holes filled): 255 foreground.
Image8 segmentByBrightness(const Image8& color, const ImportOptions& options);

// Writes the dataset into out_dir (which must not exist or be empty).
StatusOr<ImportSummary> importCapture(
    const CaptureDescription& capture, const std::string& out_dir, const ImportOptions& options,
    const std::function<void(const ImportProgress&)>& progress = {});

}  // namespace holofuse::dataset
