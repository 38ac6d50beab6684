// Calibrations stored by OpenCV's FileStorage (YAML, XML or JSON): the
// intri.yml + extri.yml pair of EasyMocap and ZJU-MoCap, or one file per
// camera as OpenCV's calibration sample writes it; and CMU Panoptic's
// calibration JSON, which holds the same K, distortion, R and t per camera.
#include <yaml-cpp/yaml.h>

#include <charconv>
#include <fstream>
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

// OpenCV's YAML parser loops for ever on some malformed files (" t:d"
// then ".cv-" on the next line, in OpenCV 4.6; found by fuzzing) and its
// parsers take time exponential in how deeply sequences nest, so a
// FileStorage file is read as a JSON tree by parsers that bound their
// work: YAML by yaml-cpp, JSON by nlohmann-json, and only XML by OpenCV.
// Before any of them the text is checked: no NUL byte, nesting at most
// kMaxNesting (a calibration nests two or three levels).
constexpr int kMaxNesting = 32;

Status checkText(const std::string& text, const fs::path& file) {
  int depth = 0;
  size_t line = 1;
  for (char c : text) {
    if (c == '\n') ++line;
    if (c == '\0') return malformed(file.string() + ":" + std::to_string(line), "holds a NUL byte");
    if (c == '[' || c == '{') ++depth;
    if (c == ']' || c == '}') depth = std::max(depth - 1, 0);
    if (depth > kMaxNesting) {
      return malformed(file.string() + ":" + std::to_string(line),
                       "nests deeper than " + std::to_string(kMaxNesting) +
                           " levels; a calibration needs three");
    }
  }
  return Status::ok();
}

// A YAML scalar as OpenCV reads it: a number where it is one and was not
// quoted, text otherwise.
nlohmann::json yamlScalar(const YAML::Node& node) {
  const std::string& text = node.Scalar();
  if (node.Tag() == "!") return text;  // quoted
  int64_t integer = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), integer);
  if (error == std::errc() && end == text.data() + text.size() && !text.empty()) return integer;
  double real = 0;
  if (parseDouble(text, real)) return real;
  return text;
}

StatusOr<nlohmann::json> fromYaml(const YAML::Node& node, const std::string& where) {
  switch (node.Type()) {
    case YAML::NodeType::Scalar:
      return yamlScalar(node);
    case YAML::NodeType::Sequence: {
      nlohmann::json array = nlohmann::json::array();
      for (const YAML::Node& child : node) {
        auto value = fromYaml(child, where);
        if (!value.isOk()) return value.status();
        array.push_back(std::move(*value));
      }
      return array;
    }
    case YAML::NodeType::Map: {
      nlohmann::json object = nlohmann::json::object();
      for (const auto& entry : node) {
        if (!entry.first.IsScalar()) return malformed(where, "a key that is not text");
        auto value = fromYaml(entry.second, where);
        if (!value.isOk()) return value.status();
        object[entry.first.Scalar()] = std::move(*value);
      }
      return object;
    }
    default:
      return nlohmann::json();
  }
}

nlohmann::json fromFileNode(const cv::FileNode& node) {
  if (node.isMap()) {
    nlohmann::json object = nlohmann::json::object();
    for (const std::string& key : node.keys()) object[key] = fromFileNode(node[key]);
    return object;
  }
  if (node.isSeq()) {
    nlohmann::json array = nlohmann::json::array();
    for (const cv::FileNode& child : node) array.push_back(fromFileNode(child));
    return array;
  }
  if (node.isInt()) return static_cast<int>(node);
  if (node.isReal()) return node.real();
  if (node.isString()) return node.string();
  return nlohmann::json();
}

// A FileStorage file (YAML, JSON or XML) as a JSON tree; a parse error
// names the file (and the line, where the parser gives one).
StatusOr<nlohmann::json> readStorage(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return Status(StatusCode::kIoError, file.string() + ": cannot open");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  HOLOFUSE_RETURN_IF_ERROR(checkText(text, file));
  const std::string ext = file.extension().string();
  if (ext == ".json") return readJson(file);
  if (ext == ".xml") {
    try {
      cv::FileStorage storage(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
      if (!storage.isOpened()) return malformed(file.string(), "not an OpenCV FileStorage file");
      return fromFileNode(storage.root());
    } catch (const std::exception& e) {
      return malformed(file.string(),
                       std::string("not an OpenCV FileStorage file (") + e.what() + ")");
    }
  }
  // OpenCV heads its YAML with "%YAML:1.0", which YAML itself does not
  // allow; the line is blanked so the parser's line numbers stay the file's.
  if (text.rfind("%YAML", 0) == 0) text.replace(0, text.find('\n'), "");
  try {
    return fromYaml(YAML::Load(text), file.string());
  } catch (const YAML::Exception& e) {
    return malformed(file.string() + ":" + std::to_string(e.mark.line + 1),
                     "not valid YAML (" + e.msg + ")");
  }
}

// document[key], or null where the document is not a map or lacks it.
const nlohmann::json& topLevel(const nlohmann::json& document, const std::string& key) {
  static const nlohmann::json none;
  if (!document.is_object()) return none;
  auto it = document.find(key);
  return it == document.end() ? none : *it;
}

// The numbers of the matrix stored under `key`, row by row: an OpenCV
// matrix (rows, cols, dt, data) or a plain list; nullopt when the key is
// absent. One of `counts` values is expected.
StatusOr<std::optional<std::vector<double>>> storedMatrix(const nlohmann::json& document,
                                                          const std::string& key,
                                                          std::initializer_list<size_t> counts,
                                                          const std::string& where) {
  const nlohmann::json& node = topLevel(document, key);
  if (node.is_null()) return std::optional<std::vector<double>>();
  const std::string at = where + ": " + key;
  const nlohmann::json* data = &node;
  if (node.is_object()) {
    const nlohmann::json& rows = topLevel(node, "rows");
    const nlohmann::json& cols = topLevel(node, "cols");
    const nlohmann::json& dt = topLevel(node, "dt");
    if (!rows.is_number_integer() || !cols.is_number_integer() || !node.contains("data"))
      return malformed(at, "not a matrix (needs rows, cols and data)");
    // One channel: OpenCV's type letter alone, or with a count of 1.
    if (dt.is_string() && !dt.get<std::string>().empty() && dt.get<std::string>() != "d" &&
        dt.get<std::string>() != "f" && dt.get<std::string>() != "i" &&
        dt.get<std::string>().front() != '1')
      return malformed(at, "not a one-channel matrix (dt " + dt.get<std::string>() + ")");
    data = &node["data"];
    const int64_t r = rows.get<int64_t>(), c = cols.get<int64_t>();
    if (r < 0 || c < 0 || r > 64 || c > 64 || static_cast<size_t>(r * c) != data->size()) {
      return malformed(at, "states " + std::to_string(r) + "x" + std::to_string(c) + " and holds " +
                               std::to_string(data->size()) + " values");
    }
  }
  std::vector<double> values;
  for (size_t count : counts) {
    auto these = numbers(*data, count, at);
    if (these.isOk()) return std::optional(*these);
    if (these.status().message().find("not finite") != std::string::npos) return these.status();
  }
  std::string expected;
  for (size_t count : counts) expected += (expected.empty() ? "" : " or ") + std::to_string(count);
  return malformed(at, "expected " + expected + " numbers");
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

StatusOr<std::vector<double>> firstMatrix(const nlohmann::json& storage,
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

std::optional<double> storedNumber(const nlohmann::json& storage,
                                   const std::vector<std::string>& keys) {
  for (const std::string& key : keys) {
    const nlohmann::json& node = topLevel(storage, key);
    if (node.is_number()) return node.get<double>();
  }
  return std::nullopt;
}

// Fills `cam` from the intrinsic and extrinsic storages (the same file
// for the one-file-per-camera layout).
Status calibrationFrom(const nlohmann::json& intrinsics, const std::string& intrinsics_where,
                       const nlohmann::json& extrinsics, const std::string& extrinsics_where,
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
  auto intri = readStorage(intri_file);
  if (!intri.isOk()) return intri.status();
  auto extri = readStorage(extri_file);
  if (!extri.isOk()) return extri.status();
  const nlohmann::json& names = topLevel(*intri, "names");
  if (!names.is_array() || names.empty()) {
    return malformed(intri_file.string(), "expected \"names\", the list of camera names");
  }
  std::vector<CaptureCamera> cameras;
  std::vector<CameraImages> images;
  for (const nlohmann::json& node : names) {
    CaptureCamera cam;
    if (node.is_string()) {
      cam.name = node.get<std::string>();
    } else if (node.is_number_integer()) {
      cam.name = std::to_string(node.get<int64_t>());
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
    auto storage = readStorage(file);
    if (!storage.isOk()) return storage.status();
    if (topLevel(*storage, "camera_matrix").is_null() && topLevel(*storage, "K").is_null())
      continue;
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
  const nlohmann::json none;
  const nlohmann::json& list =
      json->is_object() && json->contains("cameras") ? (*json)["cameras"] : none;
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
