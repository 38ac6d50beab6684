// What `./holofuse dataset verify` and `dataset info` say about a dataset
// folder: whether every record checks (and which bytes at the end a crash
// left incomplete), and what is in it, with a contact sheet a person can
// look at: every camera's image, its mask, and the visual hull carved from
// all of them projected back (silhouette IoU per camera).
#pragma once

#include <string>
#include <vector>

#include "base/status.h"
#include "dataset/camera_health.h"
#include "dataset/dataset.h"
#include "hull/visual_hull.h"

namespace holofuse::dataset {

// The hull settings a dataset asks for (its capture volume and voxel
// size), else the defaults with fallback_voxel.
hull::HullOptions hullOptionsFor(const Dataset& dataset, double fallback_voxel);

enum class VerifyVerdict {
  kClean = 0,           // every record checks and the index is in place
  kCorrupt = 1,         // a record's bytes are damaged
  kIncompleteTail = 3,  // every whole record checks; the end holds an incomplete one
};

struct VerifyReport {
  VerifyVerdict verdict = VerifyVerdict::kClean;
  std::string text;  // for people, one finding per line
};

// Checks DIR/pods.hfr and, when present, DIR/fused.hfr. A folder that is
// not a dataset, or a newer format, is an error status.
StatusOr<VerifyReport> verifyDataset(const std::string& dir);

// The first frame id every camera holds.
StatusOr<uint64_t> firstWholeFrame(const Dataset& dataset, const std::string& dir);

// Every camera's calibration and decoded planes for one frame id, in
// camera id order; dir names the dataset in errors.
struct FrameViews {
  uint64_t frame_id = 0;
  std::vector<Camera> cameras;
  std::vector<PodImagesFull> images;
};
StatusOr<FrameViews> readFrameViews(const Dataset& dataset, const std::string& dir,
                                    uint64_t frame_id);

struct CameraSummary {
  uint32_t id = 0;
  uint32_t width = 0, height = 0;
  size_t frames = 0;
  double megabytes = 0;
  std::string codecs;         // of the planes, "colour lz4-delta, mask lz4, ..."
  double silhouette_iou = 0;  // the hull carved from every camera, against this camera's mask
  CameraHealth health;        // its mask against the others' (camera_health.h)
};

struct DatasetSummary {
  std::string text;  // for people
  std::vector<CameraSummary> cameras;
  uint64_t inspected_frame_id = 0;  // the frame the sheet and the IoU come from
  HealthOverTime health_over_time;  // over frames spread through the dataset
};

// Summarises a dataset and writes the contact sheet PNG (every camera, its
// mask dimmed outside, the hull's silhouette outlined) to sheet_png. The
// hull is carved in the dataset's capture volume at its voxel size (or at
// voxel_size when positive). Mask health over time is measured on up to
// health_frames frames spread evenly through it (0: every frame).
StatusOr<DatasetSummary> describeDataset(const std::string& dir, const std::string& sheet_png,
                                         double voxel_size = 0.0, size_t health_frames = 16);

// Frame ids every camera holds, in order.
std::vector<uint64_t> wholeFrames(const Dataset& dataset);

}  // namespace holofuse::dataset
