// COLMAP's sparse model, text (cameras.txt, images.txt) or binary
// (cameras.bin, images.bin, COLMAP's default output), as its documentation
// "Output Format" describes them.
#include <cstring>
#include <fstream>
#include <glm/gtc/quaternion.hpp>
#include <map>
#include <memory>
#include <span>

#include "capture_parse.h"
#include "protocol/wire.h"

namespace holofuse::dataset {

using namespace capture;

namespace {

struct ColmapModelNames {
  const char* name;
  size_t parameters;
};

// COLMAP's camera models by the id its binary files store.
constexpr ColmapModelNames kColmapModels[] = {{"SIMPLE_PINHOLE", 3},
                                              {"PINHOLE", 4},
                                              {"SIMPLE_RADIAL", 4},
                                              {"RADIAL", 5},
                                              {"OPENCV", 8},
                                              {"OPENCV_FISHEYE", 8},
                                              {"FULL_OPENCV", 12},
                                              {"FOV", 5},
                                              {"SIMPLE_RADIAL_FISHEYE", 4},
                                              {"RADIAL_FISHEYE", 5},
                                              {"THIN_PRISM_FISHEYE", 12}};

// COLMAP's camera models as (fx, fy, cx, cy, distortion k1 k2 p1 p2 k3).
Status colmapIntrinsics(const std::string& model, const std::vector<double>& p, Camera& c,
                        const std::string& at) {
  auto need = [&](size_t n) {
    return p.size() == n
               ? Status::ok()
               : malformed(at, model + " takes " + std::to_string(n) +
                                   " parameters, the model has " + std::to_string(p.size()));
  };
  if (model == "SIMPLE_PINHOLE") {
    HOLOFUSE_RETURN_IF_ERROR(need(3));
    c.fx = c.fy = p[0], c.cx = p[1], c.cy = p[2];
  } else if (model == "PINHOLE") {
    HOLOFUSE_RETURN_IF_ERROR(need(4));
    c.fx = p[0], c.fy = p[1], c.cx = p[2], c.cy = p[3];
  } else if (model == "SIMPLE_RADIAL") {
    HOLOFUSE_RETURN_IF_ERROR(need(4));
    c.fx = c.fy = p[0], c.cx = p[1], c.cy = p[2];
    c.distortion = {p[3], 0, 0, 0, 0};
  } else if (model == "RADIAL") {
    HOLOFUSE_RETURN_IF_ERROR(need(5));
    c.fx = c.fy = p[0], c.cx = p[1], c.cy = p[2];
    c.distortion = {p[3], p[4], 0, 0, 0};
  } else if (model == "OPENCV") {
    HOLOFUSE_RETURN_IF_ERROR(need(8));
    c.fx = p[0], c.fy = p[1], c.cx = p[2], c.cy = p[3];
    c.distortion = {p[4], p[5], p[6], p[7], 0};
  } else if (model == "FULL_OPENCV") {
    HOLOFUSE_RETURN_IF_ERROR(need(12));
    if (p[9] != 0 || p[10] != 0 || p[11] != 0)
      return malformed(at, "FULL_OPENCV with k4..k6 is not supported");
    c.fx = p[0], c.fy = p[1], c.cx = p[2], c.cy = p[3];
    c.distortion = {p[4], p[5], p[6], p[7], p[8]};
  } else {
    return malformed(at, "camera model " + model +
                             " is not supported (SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, "
                             "OPENCV, FULL_OPENCV)");
  }
  return Status::ok();
}

// One registered image: its pose (world to camera) and which camera took it.
struct ColmapImage {
  std::string name;
  double pose[7];  // qw qx qy qz tx ty tz
  std::string camera_id;
  std::string at;  // file and line (text) or byte offset (binary)
};

struct ColmapModel {
  std::map<std::string, Camera> intrinsics;  // by CAMERA_ID
  std::vector<ColmapImage> images;
  std::string cameras_file;
};

StatusOr<ColmapModel> readColmapText(const fs::path& dir) {
  ColmapModel model;
  const fs::path cameras_file = dir / "cameras.txt", images_file = dir / "images.txt";
  model.cameras_file = cameras_file.string();
  auto camera_lines = contentLines(cameras_file);
  if (!camera_lines.isOk()) return camera_lines.status();
  for (const auto& [n, line] : *camera_lines) {
    const std::string at = cameras_file.string() + ":" + std::to_string(n);
    const auto w = words(line);
    if (w.size() < 4) return malformed(at, "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS...");
    Camera c;
    double width = 0, height = 0;
    if (!parseDouble(w[2], width) || !parseDouble(w[3], height) || width < 1 || height < 1) {
      return malformed(at, "WIDTH and HEIGHT must be positive numbers");
    }
    c.width = imageSide(width);
    c.height = imageSide(height);
    std::vector<double> params;
    for (size_t i = 4; i < w.size(); ++i) {
      double v = 0;
      if (!parseDouble(w[i], v))
        return malformed(at,
                         "parameter " + std::to_string(i - 3) + " '" + w[i] + "' is not a number");
      params.push_back(v);
    }
    HOLOFUSE_RETURN_IF_ERROR(colmapIntrinsics(w[1], params, c, at));
    if (model.intrinsics.count(w[0]))
      return malformed(at, "CAMERA_ID " + w[0] + " is defined twice");
    model.intrinsics[w[0]] = c;
  }
  auto image_lines = contentLines(images_file);
  if (!image_lines.isOk()) return image_lines.status();
  // images.txt holds two lines per image: the pose, then its 2D points (a
  // POINTS2D line is X Y POINT3D_ID triples, told apart by its length).
  for (size_t i = 0; i < image_lines->size(); ++i) {
    const auto& [n, line] = (*image_lines)[i];
    ColmapImage image;
    image.at = images_file.string() + ":" + std::to_string(n);
    const auto w = words(line);
    if (w.size() != 10) {
      if (w.size() % 3 == 0 && i > 0) continue;
      return malformed(image.at, "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    }
    for (int k = 0; k < 7; ++k) {
      if (!parseDouble(w[static_cast<size_t>(k) + 1], image.pose[k])) {
        return malformed(image.at, "value " + std::to_string(k + 2) + " '" +
                                       w[static_cast<size_t>(k) + 1] + "' is not a number");
      }
    }
    image.camera_id = w[8];
    image.name = w[9];
    model.images.push_back(std::move(image));
  }
  return model;
}

// A COLMAP binary file read through the wire's cursor (little-endian,
// each read checked against the file's end); a short file is named with
// the offset and the field it ends inside.
struct ColmapBinaryFile {
  std::string name;
  protocol::Bytes bytes;
  protocol::WireReader in{std::span<const uint8_t>()};

  static StatusOr<std::unique_ptr<ColmapBinaryFile>> open(const fs::path& file) {
    std::ifstream stream(file, std::ios::binary);
    if (!stream) return Status(StatusCode::kIoError, file.string() + ": cannot open");
    auto opened = std::make_unique<ColmapBinaryFile>();
    opened->name = file.string();
    opened->bytes.assign(std::istreambuf_iterator<char>(stream), std::istreambuf_iterator<char>());
    opened->in = protocol::WireReader(opened->bytes);
    return opened;
  }
  std::string at() const { return name + " at byte " + std::to_string(in.offset()); }
  Status truncated() const {
    return malformed(name + " at byte " + std::to_string(in.failedOffset()),
                     "the file ends inside " + in.failedField());
  }
};

StatusOr<ColmapModel> readColmapBinary(const fs::path& dir) {
  ColmapModel model;
  model.cameras_file = (dir / "cameras.bin").string();
  auto opened_cameras = ColmapBinaryFile::open(dir / "cameras.bin");
  if (!opened_cameras.isOk()) return opened_cameras.status();
  ColmapBinaryFile& cameras = **opened_cameras;
  const uint64_t camera_count = cameras.in.u64("the camera count");
  for (uint64_t i = 0; i < camera_count && cameras.in.ok(); ++i) {
    const std::string at = cameras.at();
    const auto id = static_cast<int32_t>(cameras.in.u32("a CAMERA_ID"));
    const auto model_id = static_cast<int32_t>(cameras.in.u32("a camera model"));
    const uint64_t width = cameras.in.u64("a width");
    const uint64_t height = cameras.in.u64("a height");
    if (!cameras.in.ok()) break;
    if (model_id < 0 || static_cast<size_t>(model_id) >= std::size(kColmapModels)) {
      return malformed(at, "camera model id " + std::to_string(model_id) + " is not COLMAP's");
    }
    const ColmapModelNames& m = kColmapModels[model_id];
    std::vector<double> params(m.parameters);
    for (double& p : params) p = cameras.in.f64("camera parameters");
    if (!cameras.in.ok()) break;
    for (const double p : params) {
      if (!std::isfinite(p)) return malformed(at, "a camera parameter is not finite");
    }
    Camera c;
    c.width = imageSide(static_cast<double>(width));
    c.height = imageSide(static_cast<double>(height));
    HOLOFUSE_RETURN_IF_ERROR(colmapIntrinsics(m.name, params, c, at));
    const std::string key = std::to_string(id);
    if (model.intrinsics.count(key)) return malformed(at, "CAMERA_ID " + key + " is defined twice");
    model.intrinsics[key] = c;
  }
  if (!cameras.in.ok()) return cameras.truncated();
  auto opened_images = ColmapBinaryFile::open(dir / "images.bin");
  if (!opened_images.isOk()) return opened_images.status();
  ColmapBinaryFile& images = **opened_images;
  const uint64_t image_count = images.in.u64("the image count");
  for (uint64_t i = 0; i < image_count && images.in.ok(); ++i) {
    ColmapImage image;
    image.at = images.at();
    images.in.u32("an IMAGE_ID");  // COLMAP's own numbering; images go by name
    for (double& v : image.pose) v = images.in.f64("a pose");
    const auto camera_id = static_cast<int32_t>(images.in.u32("a CAMERA_ID"));
    image.name = images.in.cstr("an image name");
    const uint64_t points = images.in.u64("the 2D point count");
    images.in.skip("the 2D points", points, 24);  // x, y, POINT3D_ID
    if (!images.in.ok()) break;
    for (double v : image.pose) {
      if (!std::isfinite(v)) return malformed(image.at, "the pose is not finite");
    }
    image.camera_id = std::to_string(camera_id);
    model.images.push_back(std::move(image));
  }
  if (!images.in.ok()) return images.truncated();
  if (images.in.remaining() != 0) return malformed(images.at(), "bytes after the last image");
  return model;
}

}  // namespace

StatusOr<CaptureDescription> readColmapCapture(const std::string& folder) {
  fs::path model_dir;
  bool binary = false;
  for (const char* sub : {"", "sparse", "sparse/0"}) {
    const fs::path candidate = fs::path(folder) / sub;
    if (fs::exists(candidate / "cameras.txt") && fs::exists(candidate / "images.txt")) {
      model_dir = candidate;
      break;
    }
    if (fs::exists(candidate / "cameras.bin") && fs::exists(candidate / "images.bin")) {
      model_dir = candidate;
      binary = true;
      break;
    }
  }
  if (model_dir.empty()) {
    return Status(StatusCode::kIoError,
                  folder +
                      ": no COLMAP model (cameras.txt and images.txt, or cameras.bin and "
                      "images.bin, at the root, in sparse/ or in sparse/0/)");
  }
  auto model = binary ? readColmapBinary(model_dir) : readColmapText(model_dir);
  if (!model.isOk()) return model.status();
  CaptureDescription d;
  d.source = "colmap " + folder;
  CaptureFrame frame;
  const fs::path images_dir = fs::path(folder) / "images";
  for (const ColmapImage& image : model->images) {
    const auto it = model->intrinsics.find(image.camera_id);
    if (it == model->intrinsics.end()) {
      return malformed(image.at,
                       "CAMERA_ID " + image.camera_id + " is not in " + model->cameras_file);
    }
    const double* v = image.pose;
    glm::dquat q(v[0], v[1], v[2], v[3]);  // w, x, y, z: world to camera
    const double norm = glm::length(q);
    if (!(norm > 1e-6)) return malformed(image.at, "the quaternion is zero");
    CaptureCamera cam;
    cam.name = image.name;
    cam.camera = it->second;
    cam.camera.rotation = glm::mat3_cast(q / norm);
    cam.camera.translation = glm::dvec3(v[4], v[5], v[6]);
    HOLOFUSE_RETURN_IF_ERROR(checkCamera(cam.camera, image.at));
    frame.images.push_back((images_dir / cam.name).string());
    // COLMAP's mask convention: masks/<image name>.png, zero = background.
    frame.masks.push_back(maskFor(images_dir / cam.name,
                                  {fs::path(folder) / "masks" / fs::path(cam.name).parent_path()}));
    d.cameras.push_back(std::move(cam));
  }
  if (d.cameras.empty()) return malformed(model_dir.string(), "the model lists no image");
  d.frames.push_back(std::move(frame));
  numberCamerasByName(d);
  return d;
}

}  // namespace holofuse::dataset
