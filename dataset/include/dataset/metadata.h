// A dataset's description of itself (record kind dataset_info, JSON in
// protocol/SPEC.md section 7): where it came from, the capture volume and
// voxel size its hull should be carved with, and the source's camera names
// in pod-id order. Recordings write the server's settings; imports write
// what they measured.
#pragma once

#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "base/status.h"
#include "protocol/bytes.h"

namespace holofuse::dataset {

struct DatasetMetadata {
  std::string source;  // "recording", "colmap /path", ...
  glm::dvec3 volume_min{0.0}, volume_max{0.0};
  double voxel_size = 0.0;  // metres; 0: not given
  std::vector<std::string> camera_names;
  // Per camera, the split its source put it in ("train", "val", "test" of a
  // NeRF Blender set); empty when the source has none.
  std::vector<std::string> camera_splits;
  bool still = false;        // one frame of a static scene
  std::string segmentation;  // how masks were made, for people
};

protocol::Bytes encodeDatasetMetadata(const DatasetMetadata& metadata);
// Unknown keys are ignored (a newer writer may add some).
StatusOr<DatasetMetadata> decodeDatasetMetadata(const protocol::Bytes& bytes,
                                                const std::string& where);

}  // namespace holofuse::dataset
