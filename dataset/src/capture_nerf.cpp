// NeRF-style transforms.json (instant-ngp, nerfstudio, Blender).
#include "capture_parse.h"

namespace holofuse::dataset {

using namespace capture;

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

}  // namespace holofuse::dataset
