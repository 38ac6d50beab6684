// Calibrations stored by OpenCV's FileStorage (YAML, XML or JSON): the
// intri.yml + extri.yml pair of EasyMocap and ZJU-MoCap, or one file per
// camera as OpenCV's calibration sample writes it; and CMU Panoptic's
// calibration JSON, which holds the same K, distortion, R and t per camera.
#include <glm/gtc/quaternion.hpp>
#include <map>
#include <opencv2/core.hpp>

#include "capture_parse.h"

namespace holofuse::dataset {

using namespace capture;

namespace {

// Where a rig keeps masks beside images/: masks/, EasyMocap's mask/,
// ZJU-MoCap's mask_cihp/.
std::vector<fs::path> maskRoots(const fs::path& root) {
  return {root / "masks", root / "mask", root / "mask_cihp"};
}

// A FileStorage file opened for reading; its parse errors (which carry
// OpenCV's line number) become a message naming the file.
StatusOr<cv::FileStorage> openStorage(const fs::path& file) {
  cv::FileStorage storage;
  try {
    storage.open(file.string(), cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    return malformed(file.string(), "not a readable OpenCV FileStorage file (" + e.msg + ")");
  }
  if (!storage.isOpened()) return Status(StatusCode::kIoError, file.string() + ": cannot open");
  return storage;
}

// The numbers of the matrix stored under `key`, row by row; nullopt when
// the key is absent. One of `counts` values is expected.
StatusOr<std::optional<std::vector<double>>> storedMatrix(const cv::FileStorage& storage,
                                                          const std::string& key,
                                                          std::initializer_list<size_t> counts,
                                                          const std::string& where) {
  const cv::FileNode node = storage[key];
  if (node.empty()) return std::optional<std::vector<double>>();
  cv::Mat m;
  try {
    if (node.isSeq()) {
      std::vector<double> values;
      node >> values;
      m = cv::Mat(values, true);
    } else {
      node >> m;
    }
  } catch (const cv::Exception& e) {
    return malformed(where + ": " + key, "not a matrix (" + e.msg + ")");
  }
  if (m.empty() || m.channels() != 1) return malformed(where + ": " + key, "not a matrix");
  m.convertTo(m, CV_64F);
  std::vector<double> values(m.begin<double>(), m.end<double>());
  if (std::find(counts.begin(), counts.end(), values.size()) == counts.end()) {
    return malformed(where + ": " + key, "holds " + std::to_string(values.size()) +
                                             " numbers, not as many as expected");
  }
  for (double v : values) {
    if (!std::isfinite(v)) return malformed(where + ": " + key, "holds a value that is not finite");
  }
  return std::optional(values);
}

// OpenCV's distortion vector (k1 k2 p1 p2 [k3 [k4 k5 k6 ...]]) as the
// five coefficients the import undoes; the rational terms must be zero.
Status setDistortion(const std::vector<double>& d, Camera& c, const std::string& where) {
  for (size_t i = 5; i < d.size(); ++i) {
    if (d[i] != 0) return malformed(where, "distortion beyond k1 k2 p1 p2 k3 is not supported");
  }
  c.distortion.assign(d.begin(),
                      d.begin() + static_cast<std::ptrdiff_t>(std::min<size_t>(5, d.size())));
  c.distortion.resize(5, 0.0);
  return Status::ok();
}

// R from a 3x3 matrix or a Rodrigues vector (axis times angle).
glm::dmat3 rotationFrom(const std::vector<double>& r) {
  if (r.size() == 9) return rowMajor(r);
  const glm::dvec3 v(r[0], r[1], r[2]);
  const double angle = glm::length(v);
  if (angle < 1e-15) return glm::dmat3(1.0);
  return glm::mat3_cast(glm::angleAxis(angle, v / angle));
}

// The camera `name` from FileStorage keys: K, distortion, R (3x3 or
// Rodrigues), T, and optionally the image size.
struct CalibrationKeys {
  std::vector<std::string> k, distortion, rotation, translation, width, height;
};

StatusOr<std::vector<double>> firstMatrix(const cv::FileStorage& storage,
                                          const std::vector<std::string>& keys,
                                          std::initializer_list<size_t> counts,
                                          const std::string& where, bool required) {
  for (const std::string& key : keys) {
    auto m = storedMatrix(storage, key, counts, where);
    if (!m.isOk()) return m.status();
    if (m->has_value()) return **m;
  }
  if (!required) return std::vector<double>();
  return malformed(where, "has no " + keys.front());
}

std::optional<double> storedNumber(const cv::FileStorage& storage,
                                   const std::vector<std::string>& keys) {
  for (const std::string& key : keys) {
    const cv::FileNode node = storage[key];
    if (node.isInt() || node.isReal()) return static_cast<double>(node.real());
  }
  return std::nullopt;
}

// Fills `cam` from the intrinsic and extrinsic storages (the same file
// for the one-file-per-camera layout).
Status calibrationFrom(const cv::FileStorage& intrinsics, const std::string& intrinsics_where,
                       const cv::FileStorage& extrinsics, const std::string& extrinsics_where,
                       const CalibrationKeys& keys, CaptureCamera& cam) {
  auto k = firstMatrix(intrinsics, keys.k, {9}, intrinsics_where, true);
  if (!k.isOk()) return k.status();
  HOLOFUSE_RETURN_IF_ERROR(intrinsicsFromK(*k, cam.camera, intrinsics_where + ": " + keys.k[0]));
  auto d = firstMatrix(intrinsics, keys.distortion, {4, 5, 8, 12, 14}, intrinsics_where, false);
  if (!d.isOk()) return d.status();
  if (!d->empty()) HOLOFUSE_RETURN_IF_ERROR(setDistortion(*d, cam.camera, intrinsics_where));
  auto r = firstMatrix(extrinsics, keys.rotation, {3, 9}, extrinsics_where, true);
  if (!r.isOk()) return r.status();
  auto t = firstMatrix(extrinsics, keys.translation, {3}, extrinsics_where, true);
  if (!t.isOk()) return t.status();
  cam.camera.rotation = rotationFrom(*r);
  cam.camera.translation = glm::dvec3((*t)[0], (*t)[1], (*t)[2]);
  const auto width = storedNumber(intrinsics, keys.width),
             height = storedNumber(intrinsics, keys.height);
  if (width && height) {
    cam.camera.width = imageSide(*width);
    cam.camera.height = imageSide(*height);
  }
  return Status::ok();
}

// The size from the camera's first image where the calibration has none;
// the principal point moved to holofuse's pixel centres; then checked.
Status finishCamera(CaptureCamera& cam, const CameraImages& images, const std::string& where) {
  if (images.images.empty()) {
    return malformed(where, "camera \"" + cam.name + "\" has no image (images/" + cam.name +
                                "/ or images/" + cam.name + ".<ext>)");
  }
  if (cam.camera.width == 0 || cam.camera.height == 0) {
    auto size = imageSize(images.images.front());
    if (!size.isOk()) return size.status();
    cam.camera.width = size->first;
    cam.camera.height = size->second;
  }
  pixelCentresFromZero(cam.camera);
  return checkCamera(cam.camera, where + " (camera \"" + cam.name + "\")");
}

StatusOr<CaptureDescription> describe(const std::string& source, const fs::path& where,
                                      std::vector<CaptureCamera> cameras,
                                      const std::vector<CameraImages>& images) {
  CaptureDescription d;
  d.source = source;
  auto matched = matchFrames(cameras, images, where.string());
  if (!matched.isOk()) return matched.status();
  d.fps = matched->fps.value_or(d.fps);
  d.frame_matching = std::move(matched->matching);
  d.cameras = std::move(cameras);
  d.frames = std::move(matched->frames);
  numberCamerasByName(d);
  return d;
}

std::optional<fs::path> firstExisting(const fs::path& root, const std::string& stem) {
  for (const char* ext : {".yml", ".yaml", ".xml", ".json"}) {
    if (fs::is_regular_file(root / (stem + ext))) return root / (stem + ext);
  }
  return std::nullopt;
}

StatusOr<CaptureDescription> readIntriExtri(const fs::path& root, const fs::path& intri_file,
                                            const fs::path& extri_file) {
  auto intri = openStorage(intri_file);
  if (!intri.isOk()) return intri.status();
  auto extri = openStorage(extri_file);
  if (!extri.isOk()) return extri.status();
  const cv::FileNode names = (*intri)["names"];
  if (!names.isSeq() || names.size() == 0) {
    return malformed(intri_file.string(), "expected \"names\", the list of camera names");
  }
  std::vector<CaptureCamera> cameras;
  std::vector<CameraImages> images;
  for (const cv::FileNode& node : names) {
    CaptureCamera cam;
    if (node.isString()) {
      cam.name = node.string();
    } else if (node.isInt()) {
      cam.name = std::to_string(static_cast<int>(node));
    } else {
      return malformed(intri_file.string() + ": names", "a name is neither text nor a number");
    }
    const std::string& n = cam.name;
    const CalibrationKeys keys{
        {"K_" + n}, {"dist_" + n, "D_" + n}, {"Rot_" + n, "R_" + n}, {"T_" + n}, {"W_" + n},
        {"H_" + n}};
    HOLOFUSE_RETURN_IF_ERROR(
        calibrationFrom(*intri, intri_file.string(), *extri, extri_file.string(), keys, cam));
    images.push_back(cameraImages(root / "images", n, maskRoots(root)));
    HOLOFUSE_RETURN_IF_ERROR(finishCamera(cam, images.back(), intri_file.string()));
    cameras.push_back(std::move(cam));
  }
  return describe("opencv " + root.string(), intri_file, std::move(cameras), images);
}

StatusOr<CaptureDescription> readCameraFiles(const fs::path& root) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(root)) {
    const std::string ext = entry.path().extension().string();
    if (entry.is_regular_file() &&
        (ext == ".yml" || ext == ".yaml" || ext == ".xml" || ext == ".json")) {
      files.push_back(entry.path());
    }
  }
  std::sort(files.begin(), files.end());
  std::vector<CaptureCamera> cameras;
  std::vector<CameraImages> images;
  const CalibrationKeys keys{{"camera_matrix", "K"},   {"distortion_coefficients", "dist", "D"},
                             {"R", "rvec", "Rot"},     {"T", "tvec", "t"},
                             {"image_width", "width"}, {"image_height", "height"}};
  for (const fs::path& file : files) {
    auto storage = openStorage(file);
    if (!storage.isOk()) return storage.status();
    if ((*storage)["camera_matrix"].empty() && (*storage)["K"].empty()) continue;
    CaptureCamera cam;
    cam.name = file.stem().string();
    HOLOFUSE_RETURN_IF_ERROR(
        calibrationFrom(*storage, file.string(), *storage, file.string(), keys, cam));
    CameraImages found = cameraImages(root / "images", cam.name, maskRoots(root));
    if (found.images.empty()) found = cameraImages(root, cam.name, maskRoots(root));
    images.push_back(found);
    HOLOFUSE_RETURN_IF_ERROR(finishCamera(cam, images.back(), file.string()));
    cameras.push_back(std::move(cam));
  }
  if (cameras.empty()) {
    return Status(StatusCode::kIoError,
                  root.string() +
                      ": no OpenCV calibration (intri.yml and extri.yml, or per camera a "
                      ".yml/.yaml/.xml/.json with camera_matrix)");
  }
  return describe("opencv " + root.string(), root, std::move(cameras), images);
}

}  // namespace

StatusOr<CaptureDescription> readOpencvCapture(const std::string& folder) {
  const fs::path root(folder);
  const auto intri = firstExisting(root, "intri"), extri = firstExisting(root, "extri");
  if (intri && extri) return readIntriExtri(root, *intri, *extri);
  if (intri || extri) {
    return Status(StatusCode::kIoError, folder + ": " + (intri ? "intri" : "extri") +
                                            " is there without its " + (intri ? "extri" : "intri") +
                                            " partner");
  }
  return readCameraFiles(root);
}

// ---------------------------------------------------------------- Panoptic

StatusOr<CaptureDescription> readPanopticCapture(const std::string& folder) {
  const fs::path root(folder);
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(root)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file() && name.rfind("calibration", 0) == 0 &&
        entry.path().extension() == ".json") {
      files.push_back(entry.path());
    }
  }
  if (files.size() != 1) {
    return Status(StatusCode::kIoError, folder +
                                            ": expected one calibration_<sequence>.json, found " +
                                            std::to_string(files.size()));
  }
  const fs::path file = files[0];
  auto json = readJson(file);
  if (!json.isOk()) return json.status();
  const nlohmann::json& list = (*json)["cameras"];
  if (!list.is_array() || list.empty()) {
    return malformed(file.string(), "expected a non-empty \"cameras\" array");
  }
  std::vector<CaptureCamera> cameras;
  std::vector<CameraImages> images;
  for (size_t i = 0; i < list.size(); ++i) {
    const nlohmann::json& c = list[i];
    const std::string at = file.string() + ": cameras[" + std::to_string(i) + "]";
    if (!c.is_object() || !c.contains("name") || !c["name"].is_string()) {
      return malformed(at, "missing \"name\"");
    }
    CaptureCamera cam;
    cam.name = c["name"].get<std::string>();
    const std::string type =
        c.contains("type") && c["type"].is_string() ? c["type"].get<std::string>() : "";
    CameraImages found = cameraImages(root / (type + "Imgs"), cam.name, maskRoots(root));
    if (found.images.empty()) found = cameraImages(root / "images", cam.name, maskRoots(root));
    if (found.images.empty()) {
      continue;  // Panoptic lists hundreds of VGA cameras; most captures keep HD only
    }
    if (!c.contains("resolution") || !c.contains("K") || !c.contains("R") || !c.contains("t")) {
      return malformed(at, "needs \"resolution\", \"K\", \"R\" and \"t\"");
    }
    auto size = numbers(c["resolution"], 2, at + ".resolution");
    if (!size.isOk()) return size.status();
    auto k = numbers(c["K"], 9, at + ".K");
    if (!k.isOk()) return k.status();
    auto r = numbers(c["R"], 9, at + ".R");
    if (!r.isOk()) return r.status();
    auto t = numbers(c["t"], 3, at + ".t");
    if (!t.isOk()) return t.status();
    cam.camera.width = imageSide((*size)[0]);
    cam.camera.height = imageSide((*size)[1]);
    HOLOFUSE_RETURN_IF_ERROR(intrinsicsFromK(*k, cam.camera, at + ".K"));
    if (c.contains("distCoef")) {
      if (!c["distCoef"].is_array()) return malformed(at + ".distCoef", "expected numbers");
      auto d = numbers(c["distCoef"], c["distCoef"].size(), at + ".distCoef");
      if (!d.isOk()) return d.status();
      HOLOFUSE_RETURN_IF_ERROR(setDistortion(*d, cam.camera, at + ".distCoef"));
    }
    cam.camera.rotation = rowMajor(*r);
    cam.camera.translation = glm::dvec3((*t)[0], (*t)[1], (*t)[2]);
    pixelCentresFromZero(cam.camera);
    HOLOFUSE_RETURN_IF_ERROR(checkCamera(cam.camera, at));
    images.push_back(std::move(found));
    cameras.push_back(std::move(cam));
  }
  if (cameras.empty()) {
    return malformed(file.string(), "none of its " + std::to_string(list.size()) +
                                        " cameras has images (<type>Imgs/<name>/ or "
                                        "images/<name>/)");
  }
  return describe("panoptic " + folder, file, std::move(cameras), images);
}

}  // namespace holofuse::dataset
