#include "dataset/dataset.h"

#include <filesystem>
#include <set>

#include "codec/image_codec.h"

namespace holofuse::dataset {

StatusOr<protocol::Frame> parseWholeFrame(const protocol::Bytes& bytes, const std::string& what) {
  protocol::StreamDecoder decoder;
  decoder.feed(bytes);
  if (!decoder.status().isOk())
    return Status(decoder.status().code(), what + ": " + decoder.status().message());
  if (!decoder.hasFrame() || decoder.bytesConsumed() != bytes.size()) {
    return Status(StatusCode::kMalformed, what + ": does not hold exactly one protocol frame");
  }
  protocol::Frame frame = decoder.takeFrame();
  if (decoder.hasFrame())
    return Status(StatusCode::kMalformed, what + ": holds more than one protocol frame");
  return frame;
}

StatusOr<PodImagesFull> decodePodImages(const protocol::Frame& frame, const Camera& camera) {
  protocol::PodFrame pod;
  HOLOFUSE_RETURN_IF_ERROR(protocol::decodeFrame(frame, pod));
  PodImagesFull out;
  out.frame_id = pod.frame_id;
  for (const auto& plane : pod.planes) {
    out.codecs.push_back(plane.codec);
    if (uint64_t{pod.offset_x} + plane.width > camera.width ||
        uint64_t{pod.offset_y} + plane.height > camera.height) {
      return Status(StatusCode::kMalformed,
                    "a " + std::to_string(plane.width) + "x" + std::to_string(plane.height) +
                        " plane at (" + std::to_string(pod.offset_x) + ", " +
                        std::to_string(pod.offset_y) + ") does not fit camera " +
                        std::to_string(camera.id) + "'s " + std::to_string(camera.width) + "x" +
                        std::to_string(camera.height) + " image");
    }
    auto image = decodePlane(plane);
    if (!image.isOk()) return image.status();
    Image8 whole = placeInFrame(*image, pod.offset_x, pod.offset_y, camera.width, camera.height);
    switch (plane.kind) {
      case protocol::PlaneKind::kColor:
        out.color = std::move(whole);
        break;
      case protocol::PlaneKind::kMask:
        out.mask = std::move(whole);
        break;
      case protocol::PlaneKind::kFeather:
        out.feather = std::move(whole);
        break;
      case protocol::PlaneKind::kDepth:
      case protocol::PlaneKind::kCamera:  // a texture layer's: not a pod's
        break;
    }
  }
  if (out.color.channels != 3 || out.mask.channels != 1) {
    return Status(StatusCode::kMalformed, "a PodFrame needs an RGB colour and a grey mask plane");
  }
  return out;
}

StatusOr<Dataset> Dataset::open(const std::string& path) {
  namespace fs = std::filesystem;
  std::string file = path;
  if (fs::is_directory(path)) {
    file = (fs::path(path) / kDatasetPodsFile).string();
    if (!fs::exists(file)) {
      return Status(StatusCode::kIoError,
                    path + ": not a holofuse dataset (no " + kDatasetPodsFile + " in it)");
    }
  }
  auto reader = RecordReader::open(file);
  if (!reader.isOk()) return reader.status();
  Dataset dataset;
  dataset.reader_ = std::move(*reader);
  std::set<uint64_t> ids;
  bool first = true;
  for (const auto& r : dataset.reader_.records()) {
    if (r.kind == static_cast<uint16_t>(RecordKind::kCalibration)) {
      DatasetCamera& cam = dataset.cameras_[r.stream];
      cam.id = r.stream;
      if (!cam.calibration) cam.calibration = r;
    } else if (r.kind == static_cast<uint16_t>(RecordKind::kPodFrame)) {
      DatasetCamera& cam = dataset.cameras_[r.stream];
      cam.id = r.stream;
      cam.frames.push_back(r);
      cam.frame_bytes += r.payload_length;
      ids.insert(r.frame_id);
      if (first) {
        dataset.first_id_ = dataset.last_id_ = r.frame_id;
        dataset.first_time_ = dataset.last_time_ = r.time_ns;
        first = false;
      }
      dataset.first_id_ = std::min(dataset.first_id_, r.frame_id);
      dataset.last_id_ = std::max(dataset.last_id_, r.frame_id);
      dataset.first_time_ = std::min(dataset.first_time_, r.time_ns);
      dataset.last_time_ = std::max(dataset.last_time_, r.time_ns);
    }
    if (r.kind == static_cast<uint16_t>(RecordKind::kDatasetInfo) && !dataset.metadata_) {
      auto bytes = dataset.reader_.read(r);
      if (!bytes.isOk()) return bytes.status();
      auto metadata = decodeDatasetMetadata(
          *bytes, file + ": the dataset_info record at byte " + std::to_string(r.offset));
      if (!metadata.isOk()) return metadata.status();
      dataset.metadata_ = std::move(*metadata);
    }
    // Other kinds (a newer minor's) are skipped.
  }
  dataset.frame_ids_ = ids.size();
  return dataset;
}

StatusOr<protocol::Calibration> Dataset::readCalibration(uint32_t camera_id) const {
  const auto it = cameras_.find(camera_id);
  if (it == cameras_.end() || !it->second.calibration) {
    std::string have;
    for (const auto& [id, cam] : cameras_) {
      if (cam.calibration) have += (have.empty() ? "" : ", ") + std::to_string(id);
    }
    return Status(StatusCode::kMalformed,
                  reader_.path() + " has no calibration for camera " + std::to_string(camera_id) +
                      " (cameras with one: " + (have.empty() ? std::string("none") : have) + ")");
  }
  auto frame = readFrame(*it->second.calibration);
  if (!frame.isOk()) return frame.status();
  protocol::Calibration calibration;
  const Status decoded = protocol::decodeFrame(*frame, calibration);
  if (!decoded.isOk()) {
    return Status(decoded.code(), reader_.path() + ": camera " + std::to_string(camera_id) +
                                      "'s calibration: " + decoded.message());
  }
  return calibration;
}

StatusOr<protocol::Frame> Dataset::readFrame(const RecordInfo& record) const {
  auto bytes = reader_.read(record);
  if (!bytes.isOk()) return bytes.status();
  return parseWholeFrame(*bytes, reader_.path() + ": the " + recordKindName(record.kind) +
                                     " record at byte " + std::to_string(record.offset));
}

}  // namespace holofuse::dataset
