#include "dataset/metadata.h"

#include <cmath>
#include <nlohmann/json.hpp>

namespace holofuse::dataset {

protocol::Bytes encodeDatasetMetadata(const DatasetMetadata& m) {
  nlohmann::json j;
  j["source"] = m.source;
  j["volume_min"] = {m.volume_min.x, m.volume_min.y, m.volume_min.z};
  j["volume_max"] = {m.volume_max.x, m.volume_max.y, m.volume_max.z};
  j["voxel_size"] = m.voxel_size;
  j["camera_names"] = m.camera_names;
  if (!m.camera_splits.empty()) j["camera_splits"] = m.camera_splits;
  j["still"] = m.still;
  j["segmentation"] = m.segmentation;
  const std::string text = j.dump(2);
  return protocol::Bytes(text.begin(), text.end());
}

StatusOr<DatasetMetadata> decodeDatasetMetadata(const protocol::Bytes& bytes,
                                                const std::string& where) {
  DatasetMetadata m;
  try {
    const auto j = nlohmann::json::parse(bytes.begin(), bytes.end());
    m.source = j.value("source", "");
    auto vec = [&](const char* key, glm::dvec3& out) {
      if (!j.contains(key)) return true;
      const auto& v = j[key];
      if (!v.is_array() || v.size() != 3) return false;
      for (int k = 0; k < 3; ++k) {
        out[k] = v[static_cast<size_t>(k)].get<double>();
        if (!std::isfinite(out[k])) return false;
      }
      return true;
    };
    if (!vec("volume_min", m.volume_min) || !vec("volume_max", m.volume_max)) {
      return Status(StatusCode::kMalformed,
                    where + ": volume_min and volume_max must be three finite numbers");
    }
    m.voxel_size = j.value("voxel_size", 0.0);
    if (!(m.voxel_size >= 0.0) || !std::isfinite(m.voxel_size)) {
      return Status(StatusCode::kMalformed, where + ": voxel_size must be a non-negative number");
    }
    if (j.contains("camera_names"))
      m.camera_names = j["camera_names"].get<std::vector<std::string>>();
    if (j.contains("camera_splits"))
      m.camera_splits = j["camera_splits"].get<std::vector<std::string>>();
    m.still = j.value("still", false);
    m.segmentation = j.value("segmentation", "");
  } catch (const nlohmann::json::exception& e) {
    return Status(StatusCode::kMalformed,
                  where + ": dataset metadata is not the expected JSON (" + e.what() + ")");
  }
  return m;
}

}  // namespace holofuse::dataset
