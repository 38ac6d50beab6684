// A holofuse dataset: a folder whose pods.hfr holds what pods sent
// (Calibration and PodFrames, as protocol frames) and, optionally,
// fused.hfr the server's output (protocol/SPEC.md section 7). Recordings
// and imported captures share this layout, so both replay the same way.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dataset/metadata.h"
#include "dataset/record_file.h"
#include "geometry/camera.h"
#include "image/image.h"
#include "protocol/frame.h"
#include "protocol/messages.h"

namespace holofuse::dataset {

constexpr const char* kDatasetPodsFile = "pods.hfr";
constexpr const char* kDatasetFusedFile = "fused.hfr";

// One camera's records in a dataset.
struct DatasetCamera {
  uint32_t id = 0;
  std::optional<RecordInfo> calibration;  // the first one recorded
  std::vector<RecordInfo> frames;         // PodFrames in recorded order
  uint64_t frame_bytes = 0;
};

class Dataset {
 public:
  // Opens DIR/pods.hfr (or a .hfr file named directly), refusing a newer
  // format by version and a folder without a recording by name.
  static StatusOr<Dataset> open(const std::string& path);

  const RecordReader& records() const { return reader_; }
  const std::map<uint32_t, DatasetCamera>& cameras() const { return cameras_; }
  // Over every camera: the first and last PodFrame ids and receive times.
  uint64_t firstFrameId() const { return first_id_; }
  uint64_t lastFrameId() const { return last_id_; }
  uint64_t firstTimeNs() const { return first_time_; }
  uint64_t lastTimeNs() const { return last_time_; }
  // Distinct frame ids over every camera.
  size_t frameIds() const { return frame_ids_; }
  // The dataset's own description (imports and newer recordings).
  const std::optional<DatasetMetadata>& metadata() const { return metadata_; }

  // A camera's first recorded calibration, decoded; errors name the camera.
  StatusOr<protocol::Calibration> readCalibration(uint32_t camera_id) const;

  // Reads a record and parses it as a whole, checked protocol frame.
  StatusOr<protocol::Frame> readFrame(const RecordInfo& record) const;

 private:
  RecordReader reader_;
  std::map<uint32_t, DatasetCamera> cameras_;
  uint64_t first_id_ = 0, last_id_ = 0, first_time_ = 0, last_time_ = 0;
  size_t frame_ids_ = 0;
  std::optional<DatasetMetadata> metadata_;
};

// A recorded PodFrame's images, decompressed and placed back into the
// camera's whole image (a pod may send only its foreground's rectangle).
struct PodImagesFull {
  uint64_t frame_id = 0;
  Image8 color, mask, feather;
  std::vector<protocol::Codec> codecs;  // per plane, in the frame's order
};
// Checks the planes against the camera before decompressing anything.
StatusOr<PodImagesFull> decodePodImages(const protocol::Frame& frame, const Camera& camera);

// Parses bytes holding exactly one protocol frame (header checked, CRC
// checked); what names the source in errors.
StatusOr<protocol::Frame> parseWholeFrame(const protocol::Bytes& bytes, const std::string& what);

}  // namespace holofuse::dataset
