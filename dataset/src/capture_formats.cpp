#include "dataset/capture_formats.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/gtc/quaternion.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

namespace holofuse::dataset {

namespace fs = std::filesystem;

namespace {

Status malformed(const std::string& where, const std::string& what) {
  return Status(StatusCode::kMalformed, where + ": " + what);
}

// JSON from a file; a syntax error is named with its line and column.
StatusOr<nlohmann::json> readJson(const fs::path& file) {
  std::ifstream in(file);
  if (!in) return Status(StatusCode::kIoError, file.string() + ": cannot open");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    const size_t at = std::min(e.byte == 0 ? 0 : e.byte - 1, text.size());
    const size_t line =
        1 + static_cast<size_t>(
                std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
    const size_t line_start = text.rfind('\n', at == 0 ? 0 : at - 1);
    const size_t column = line_start == std::string::npos ? at + 1 : at - line_start;
    return malformed(file.string() + ":" + std::to_string(line) + ":" + std::to_string(column),
                     "not valid JSON (" + std::string(e.what()) + ")");
  }
}

// A number at a JSON path, or a message naming the path.
StatusOr<double> number(const nlohmann::json& object, const std::string& key,
                        const std::string& where) {
  if (!object.is_object() || !object.contains(key))
    return malformed(where, "missing \"" + key + "\"");
  if (!object[key].is_number()) return malformed(where + "." + key, "expected a number");
  return object[key].get<double>();
}

StatusOr<std::vector<double>> numbers(const nlohmann::json& value, size_t count,
                                      const std::string& where) {
  std::vector<double> out;
  auto flat = [&](const nlohmann::json& v, auto&& self) -> bool {
    if (v.is_number()) {
      out.push_back(v.get<double>());
      return true;
    }
    if (!v.is_array()) return false;
    for (const auto& e : v) {
      if (!self(e, self)) return false;
    }
    return true;
  };
  if (!flat(value, flat) || out.size() != count) {
    return malformed(where, "expected " + std::to_string(count) + " numbers");
  }
  for (double x : out) {
    if (!std::isfinite(x)) return malformed(where, "holds a value that is not finite");
  }
  return out;
}

Status checkCamera(const Camera& c, const std::string& where) {
  if (c.width == 0 || c.height == 0 || c.width > 16384 || c.height > 16384) {
    return malformed(where, "image size " + std::to_string(c.width) + "x" +
                                std::to_string(c.height) + " outside 1..16384");
  }
  if (!(c.fx > 0) || !(c.fy > 0) || !std::isfinite(c.cx) || !std::isfinite(c.cy) ||
      !std::isfinite(c.skew)) {
    return malformed(where, "focal lengths must be positive and every intrinsic finite");
  }
  // A rotation: orthonormal with determinant +1.
  const glm::dmat3 should_be_identity = glm::transpose(c.rotation) * c.rotation;
  double error = std::abs(glm::determinant(c.rotation) - 1.0);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) error += std::abs(should_be_identity[i][j] - (i == j ? 1.0 : 0.0));
  }
  if (!(error < 1e-3)) return malformed(where, "R is not a rotation (orthonormal, determinant 1)");
  return Status::ok();
}

// An image side from an untrusted number: out-of-range values become 0 or
// 16385 (refused by checkCamera) instead of an undefined conversion.
uint32_t imageSide(double value) {
  if (!(value >= 0)) return 0;
  return static_cast<uint32_t>(std::min(value, 16385.0));
}

glm::dmat3 rowMajor(const std::vector<double>& m) {
  glm::dmat3 r;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) r[col][row] = m[static_cast<size_t>(3 * row + col)];
  }
  return r;
}

std::string relativeTo(const fs::path& folder, const std::string& file) {
  const fs::path p(file);
  return p.is_absolute() ? p.string() : (folder / p).lexically_normal().string();
}

}  // namespace

std::optional<CaptureFormat> captureFormatFromName(const std::string& name) {
  if (name == "holofuse") return CaptureFormat::kHolofuse;
  if (name == "colmap") return CaptureFormat::kColmap;
  if (name == "nerf") return CaptureFormat::kNerf;
  return std::nullopt;
}

const char* captureFormatNames() { return "holofuse, colmap, nerf"; }

bool naturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) &&
        std::isdigit(static_cast<unsigned char>(b[j]))) {
      size_t i_end = i, j_end = j;
      while (i_end < a.size() && std::isdigit(static_cast<unsigned char>(a[i_end]))) ++i_end;
      while (j_end < b.size() && std::isdigit(static_cast<unsigned char>(b[j_end]))) ++j_end;
      // Compare digit runs as numbers: strip leading zeros, then by length.
      size_t ia = i, jb = j;
      while (ia + 1 < i_end && a[ia] == '0') ++ia;
      while (jb + 1 < j_end && b[jb] == '0') ++jb;
      const std::string na = a.substr(ia, i_end - ia), nb = b.substr(jb, j_end - jb);
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      i = i_end;
      j = j_end;
      continue;
    }
    if (a[i] != b[j]) return a[i] < b[j];
    ++i;
    ++j;
  }
  return a.size() - i < b.size() - j;
}

void numberCamerasByName(CaptureDescription& d) {
  std::vector<size_t> order(d.cameras.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t x, size_t y) {
    return naturalLess(d.cameras[x].name, d.cameras[y].name);
  });
  CaptureDescription sorted = d;
  for (size_t k = 0; k < order.size(); ++k) {
    sorted.cameras[k] = d.cameras[order[k]];
    sorted.cameras[k].camera.id = static_cast<uint32_t>(k);
    for (size_t f = 0; f < d.frames.size(); ++f) {
      sorted.frames[f].images[k] = d.frames[f].images[order[k]];
      sorted.frames[f].masks[k] = d.frames[f].masks[order[k]];
    }
  }
  d = std::move(sorted);
}

StatusOr<CaptureDescription> withoutCameras(const CaptureDescription& d,
                                            const std::vector<std::string>& names) {
  for (const std::string& name : names) {
    const bool known = std::any_of(d.cameras.begin(), d.cameras.end(),
                                   [&](const CaptureCamera& c) { return c.name == name; });
    if (!known) {
      std::string all;
      for (const auto& c : d.cameras) all += (all.empty() ? "" : ", ") + c.name;
      return Status(StatusCode::kMalformed,
                    d.source + ": no camera named \"" + name + "\" to exclude; cameras: " + all);
    }
  }
  CaptureDescription kept = d;
  kept.cameras.clear();
  for (auto& frame : kept.frames) {
    frame.images.clear();
    frame.masks.clear();
  }
  for (size_t c = 0; c < d.cameras.size(); ++c) {
    if (std::find(names.begin(), names.end(), d.cameras[c].name) != names.end()) continue;
    kept.cameras.push_back(d.cameras[c]);
    kept.cameras.back().camera.id = static_cast<uint32_t>(kept.cameras.size() - 1);
    for (size_t f = 0; f < d.frames.size(); ++f) {
      kept.frames[f].images.push_back(d.frames[f].images[c]);
      kept.frames[f].masks.push_back(d.frames[f].masks[c]);
    }
  }
  return kept;
}

// ----------------------------------------------------------- holofuse JSON

StatusOr<CaptureDescription> readHolofuseCapture(const std::string& folder) {
  const fs::path file = fs::path(folder) / "capture.json";
  auto json = readJson(file);
  if (!json.isOk()) return json.status();
  const nlohmann::json& root = *json;
  const std::string where = file.string();
  if (!root.is_object() || root.value("format", "") != "holofuse-capture") {
    return malformed(where, "expected \"format\": \"holofuse-capture\"");
  }
  if (!root.contains("version") || !root["version"].is_number_integer())
    return malformed(where, "missing \"version\"");
  if (root["version"].get<int>() > 1) {
    return Status(StatusCode::kUnsupportedVersion, where + ": capture format version " +
                                                       std::to_string(root["version"].get<int>()) +
                                                       " is newer than this holofuse reads (1)");
  }
  CaptureDescription d;
  d.source = "holofuse " + folder;
  if (root.contains("fps")) {
    auto fps = number(root, "fps", where);
    if (!fps.isOk()) return fps.status();
    if (!(*fps > 0 && *fps <= 1000)) return malformed(where + ".fps", "outside (0, 1000]");
    d.fps = *fps;
  }
  if (!root.contains("cameras") || !root["cameras"].is_array() || root["cameras"].empty()) {
    return malformed(where, "expected a non-empty \"cameras\" array");
  }
  std::map<std::string, size_t> by_name;
  for (size_t i = 0; i < root["cameras"].size(); ++i) {
    const nlohmann::json& c = root["cameras"][i];
    const std::string at = where + ": cameras[" + std::to_string(i) + "]";
    CaptureCamera cam;
    if (!c.is_object() || !c.contains("name") || !c["name"].is_string())
      return malformed(at, "missing \"name\"");
    cam.name = c["name"].get<std::string>();
    if (by_name.count(cam.name))
      return malformed(at, "camera name \"" + cam.name + "\" is used twice");
    auto width = number(c, "width", at), height = number(c, "height", at);
    if (!width.isOk()) return width.status();
    if (!height.isOk()) return height.status();
    cam.camera.width = imageSide(*width);
    cam.camera.height = imageSide(*height);
    if (!c.contains("K")) return malformed(at, "missing \"K\"");
    auto k = numbers(c["K"], 9, at + ".K");
    if (!k.isOk()) return k.status();
    cam.camera.fx = (*k)[0];
    cam.camera.skew = (*k)[1];
    cam.camera.cx = (*k)[2];
    cam.camera.fy = (*k)[4];
    cam.camera.cy = (*k)[5];
    if ((*k)[3] != 0 || (*k)[6] != 0 || (*k)[7] != 0 || (*k)[8] != 1) {
      return malformed(at + ".K", "expected [[fx, skew, cx], [0, fy, cy], [0, 0, 1]]");
    }
    if (c.contains("distortion")) {
      if (!c["distortion"].is_array() || c["distortion"].size() > 5) {
        return malformed(at + ".distortion", "expected up to 5 numbers k1 k2 p1 p2 k3");
      }
      auto dist = numbers(c["distortion"], c["distortion"].size(), at + ".distortion");
      if (!dist.isOk()) return dist.status();
      cam.camera.distortion = *dist;
    }
    if (!c.contains("R") || !c.contains("t"))
      return malformed(at, "missing \"R\" or \"t\" (world to camera)");
    auto r = numbers(c["R"], 9, at + ".R");
    if (!r.isOk()) return r.status();
    auto t = numbers(c["t"], 3, at + ".t");
    if (!t.isOk()) return t.status();
    cam.camera.rotation = rowMajor(*r);
    cam.camera.translation = glm::dvec3((*t)[0], (*t)[1], (*t)[2]);
    HOLOFUSE_RETURN_IF_ERROR(checkCamera(cam.camera, at));
    if (c.contains("background")) {
      if (!c["background"].is_string())
        return malformed(at + ".background", "expected a file name");
      cam.background = relativeTo(folder, c["background"].get<std::string>());
    }
    by_name[cam.name] = i;
    d.cameras.push_back(std::move(cam));
  }
  if (!root.contains("frames") || !root["frames"].is_array() || root["frames"].empty()) {
    return malformed(where, "expected a non-empty \"frames\" array");
  }
  for (size_t f = 0; f < root["frames"].size(); ++f) {
    const nlohmann::json& frame = root["frames"][f];
    const std::string at = where + ": frames[" + std::to_string(f) + "]";
    if (!frame.is_object() || !frame.contains("images") || !frame["images"].is_object()) {
      return malformed(at, "missing \"images\" (camera name -> file)");
    }
    CaptureFrame out;
    out.images.resize(d.cameras.size());
    out.masks.resize(d.cameras.size());
    for (const auto& [name, file] : frame["images"].items()) {
      if (!by_name.count(name))
        return malformed(at + ".images", "camera \"" + name + "\" is not in \"cameras\"");
      if (!file.is_string()) return malformed(at + ".images." + name, "expected a file name");
      out.images[by_name[name]] = relativeTo(folder, file.get<std::string>());
    }
    if (frame["images"].size() != d.cameras.size()) {
      return malformed(at + ".images", "has " + std::to_string(frame["images"].size()) +
                                           " cameras, \"cameras\" has " +
                                           std::to_string(d.cameras.size()));
    }
    if (frame.contains("masks")) {
      if (!frame["masks"].is_object())
        return malformed(at + ".masks", "expected camera name -> file");
      for (const auto& [name, file] : frame["masks"].items()) {
        if (!by_name.count(name))
          return malformed(at + ".masks", "camera \"" + name + "\" is not in \"cameras\"");
        if (!file.is_string()) return malformed(at + ".masks." + name, "expected a file name");
        out.masks[by_name[name]] = relativeTo(folder, file.get<std::string>());
      }
    }
    d.frames.push_back(std::move(out));
  }
  numberCamerasByName(d);
  return d;
}

// ------------------------------------------------------------------ COLMAP

namespace {

// Lines of a COLMAP text file without comments and blank lines, with their
// line numbers.
StatusOr<std::vector<std::pair<size_t, std::string>>> colmapLines(const fs::path& file) {
  std::ifstream in(file);
  if (!in) return Status(StatusCode::kIoError, file.string() + ": cannot open");
  std::vector<std::pair<size_t, std::string>> lines;
  std::string line;
  for (size_t n = 1; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    lines.emplace_back(n, line);
  }
  return lines;
}

// COLMAP's camera models, as (fx, fy, cx, cy, distortion k1 k2 p1 p2 k3).
Status colmapIntrinsics(const std::string& model, const std::vector<double>& p, Camera& c,
                        const std::string& at) {
  auto need = [&](size_t n) {
    return p.size() == n
               ? Status::ok()
               : malformed(at, model + " takes " + std::to_string(n) +
                                   " parameters, the line has " + std::to_string(p.size()));
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

std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

bool parseDouble(const std::string& text, double& value) {
  char* end = nullptr;
  value = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0' && std::isfinite(value);
}

}  // namespace

StatusOr<CaptureDescription> readColmapCapture(const std::string& folder) {
  fs::path model_dir;
  for (const char* sub : {"", "sparse", "sparse/0"}) {
    const fs::path candidate = fs::path(folder) / sub;
    if (fs::exists(candidate / "cameras.txt") && fs::exists(candidate / "images.txt")) {
      model_dir = candidate;
      break;
    }
  }
  if (model_dir.empty()) {
    return Status(StatusCode::kIoError,
                  folder +
                      ": no COLMAP text model (cameras.txt and images.txt at the root, in "
                      "sparse/ or in sparse/0/)");
  }
  const fs::path cameras_file = model_dir / "cameras.txt", images_file = model_dir / "images.txt";
  auto camera_lines = colmapLines(cameras_file);
  if (!camera_lines.isOk()) return camera_lines.status();
  std::map<std::string, Camera> intrinsics;
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
    if (intrinsics.count(w[0])) return malformed(at, "CAMERA_ID " + w[0] + " is defined twice");
    intrinsics[w[0]] = c;
  }
  auto image_lines = colmapLines(images_file);
  if (!image_lines.isOk()) return image_lines.status();
  CaptureDescription d;
  d.source = "colmap " + folder;
  CaptureFrame frame;
  const fs::path images_dir = fs::path(folder) / "images", masks_dir = fs::path(folder) / "masks";
  // images.txt holds two lines per image: the pose, then its 2D points
  // (which may be empty and then is skipped as blank by colmapLines only
  // when it is truly empty; a points line is recognised by its length).
  for (size_t i = 0; i < image_lines->size(); ++i) {
    const auto& [n, line] = (*image_lines)[i];
    const std::string at = images_file.string() + ":" + std::to_string(n);
    const auto w = words(line);
    if (w.size() != 10) {
      // A POINTS2D line (X Y POINT3D_ID triples) after an image line.
      if (w.size() % 3 == 0 && i > 0) continue;
      return malformed(at, "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    }
    double v[7];
    for (int k = 0; k < 7; ++k) {
      if (!parseDouble(w[static_cast<size_t>(k) + 1], v[k])) {
        return malformed(at, "value " + std::to_string(k + 2) + " '" +
                                 w[static_cast<size_t>(k) + 1] + "' is not a number");
      }
    }
    const auto it = intrinsics.find(w[8]);
    if (it == intrinsics.end()) {
      return malformed(at, "CAMERA_ID " + w[8] + " is not in " + cameras_file.string());
    }
    glm::dquat q(v[0], v[1], v[2], v[3]);  // w, x, y, z: world to camera
    const double norm = glm::length(q);
    if (!(norm > 1e-6)) return malformed(at, "the quaternion is zero");
    CaptureCamera cam;
    cam.name = w[9];
    cam.camera = it->second;
    cam.camera.rotation = glm::mat3_cast(q / norm);
    cam.camera.translation = glm::dvec3(v[4], v[5], v[6]);
    HOLOFUSE_RETURN_IF_ERROR(checkCamera(cam.camera, at));
    frame.images.push_back((images_dir / cam.name).string());
    // COLMAP's mask convention: masks/<image name>.png, zero = background.
    const fs::path mask = masks_dir / (cam.name + ".png");
    frame.masks.push_back(fs::exists(mask) ? std::optional<std::string>(mask.string())
                                           : std::nullopt);
    d.cameras.push_back(std::move(cam));
  }
  if (d.cameras.empty()) return malformed(images_file.string(), "lists no image");
  d.frames.push_back(std::move(frame));
  numberCamerasByName(d);
  return d;
}

// -------------------------------------------------------------------- NeRF

StatusOr<CaptureDescription> readNerfCapture(const std::string& folder) {
  const fs::path file = fs::path(folder) / "transforms.json";
  auto json = readJson(file);
  if (!json.isOk()) return json.status();
  const nlohmann::json& root = *json;
  const std::string where = file.string();
  if (!root.is_object() || !root.contains("frames") || !root["frames"].is_array() ||
      root["frames"].empty()) {
    return malformed(where, "expected a non-empty \"frames\" array");
  }
  CaptureDescription d;
  d.source = "nerf " + folder;
  CaptureFrame frame;
  for (size_t i = 0; i < root["frames"].size(); ++i) {
    const nlohmann::json& f = root["frames"][i];
    const std::string at = where + ": frames[" + std::to_string(i) + "]";
    if (!f.is_object() || !f.contains("file_path") || !f["file_path"].is_string()) {
      return malformed(at, "missing \"file_path\"");
    }
    // Per-frame intrinsics override the shared ones (nerfstudio).
    auto value = [&](const char* key) -> std::optional<double> {
      if (f.contains(key) && f[key].is_number()) return f[key].get<double>();
      if (root.contains(key) && root[key].is_number()) return root[key].get<double>();
      return std::nullopt;
    };
    Camera c;
    const auto w = value("w"), h = value("h");
    if (!w || !h)
      return malformed(at, "needs the image size \"w\" and \"h\" (here or at the top level)");
    c.width = imageSide(*w);
    c.height = imageSide(*h);
    const auto fl_x = value("fl_x"), angle_x = value("camera_angle_x");
    if (fl_x) {
      c.fx = *fl_x;
    } else if (angle_x && *angle_x > 0 && *angle_x < 3.14) {
      c.fx = 0.5 * c.width / std::tan(0.5 * *angle_x);
    } else {
      return malformed(at, "needs \"fl_x\" or \"camera_angle_x\"");
    }
    const auto fl_y = value("fl_y"), angle_y = value("camera_angle_y");
    c.fy = fl_y ? *fl_y
                : (angle_y && *angle_y > 0 && *angle_y < 3.14
                       ? 0.5 * c.height / std::tan(0.5 * *angle_y)
                       : c.fx);
    c.cx = value("cx").value_or(0.5 * c.width);
    c.cy = value("cy").value_or(0.5 * c.height);
    const double k1 = value("k1").value_or(0), k2 = value("k2").value_or(0),
                 p1 = value("p1").value_or(0), p2 = value("p2").value_or(0),
                 k3 = value("k3").value_or(0);
    if (k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0) c.distortion = {k1, k2, p1, p2, k3};
    if (!f.contains("transform_matrix")) return malformed(at, "missing \"transform_matrix\"");
    auto m = numbers(f["transform_matrix"], 16, at + ".transform_matrix");
    if (!m.isOk()) return m.status();
    // Camera to world in OpenGL axes; OpenCV's camera axes are OpenGL's
    // with y and z negated.
    glm::dmat3 to_world;
    glm::dvec3 centre;
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) {
        to_world[col][row] = (*m)[static_cast<size_t>(4 * row + col)] * (col == 0 ? 1.0 : -1.0);
      }
      centre[row] = (*m)[static_cast<size_t>(4 * row + 3)];
    }
    c.rotation = glm::transpose(to_world);
    c.translation = -(c.rotation * centre);
    HOLOFUSE_RETURN_IF_ERROR(checkCamera(c, at));
    CaptureCamera cam;
    std::string path = f["file_path"].get<std::string>();
    // Blender's sets name files without their extension.
    const fs::path resolved = relativeTo(folder, path);
    std::string image = resolved.string();
    if (!resolved.has_extension() ||
        (!fs::exists(resolved) && fs::exists(resolved.string() + ".png"))) {
      image = resolved.string() + ".png";
    }
    cam.name = fs::path(path).filename().string();
    cam.camera = c;
    frame.images.push_back(image);
    const fs::path mask =
        fs::path(folder) / "masks" / (fs::path(image).filename().string() + ".png");
    frame.masks.push_back(fs::exists(mask) ? std::optional<std::string>(mask.string())
                                           : std::nullopt);
    d.cameras.push_back(std::move(cam));
  }
  std::map<std::string, int> names;
  for (const auto& c : d.cameras) {
    if (++names[c.name] > 1)
      return malformed(where, "two frames name the same image \"" + c.name + "\"");
  }
  d.frames.push_back(std::move(frame));
  numberCamerasByName(d);
  return d;
}

StatusOr<CaptureDescription> readCapture(const std::string& folder, CaptureFormat format) {
  if (!fs::is_directory(folder)) return Status(StatusCode::kIoError, folder + ": not a folder");
  switch (format) {
    case CaptureFormat::kHolofuse:
      return readHolofuseCapture(folder);
    case CaptureFormat::kColmap:
      return readColmapCapture(folder);
    case CaptureFormat::kNerf:
      return readNerfCapture(folder);
  }
  return Status(StatusCode::kMalformed, "unknown capture format");
}

}  // namespace holofuse::dataset
