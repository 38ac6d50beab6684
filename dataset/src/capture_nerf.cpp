// NeRF-style transforms.json (instant-ngp, nerfstudio), and the Blender
// layout of the NeRF synthetic scenes: transforms_train.json,
// transforms_val.json and transforms_test.json, the split kept per camera.
#include "capture_parse.h"

namespace holofuse::dataset {

using namespace capture;

namespace {

// The camera models read as perspective with radial-tangential distortion
// (nerfstudio's OPENCV, its default; COLMAP's pinhole names).
bool perspectiveModel(const std::string& model) {
  return model == "OPENCV" || model == "PINHOLE" || model == "SIMPLE_PINHOLE";
}

// One transforms file's frames as cameras of `d` and images of `frame`;
// a camera of a split is named "split/file".
Status readTransforms(const std::string& folder, const fs::path& file, const std::string& split,
                      CaptureDescription& d, CaptureFrame& frame) {
  auto json = readJson(file);
  if (!json.isOk()) return json.status();
  const nlohmann::json& root = *json;
  const std::string where = file.string();
  if (!root.is_object() || !root.contains("frames") || !root["frames"].is_array() ||
      root["frames"].empty()) {
    return malformed(where, "expected a non-empty \"frames\" array");
  }
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
    // nerfstudio's camera_model: a fisheye or a panorama projects unlike
    // the pinhole the fusion and the blend assume.
    const nlohmann::json& model_at = f.contains("camera_model") ? f : root;
    if (model_at.contains("camera_model")) {
      const std::string model =
          model_at["camera_model"].is_string() ? model_at["camera_model"].get<std::string>() : "";
      if (!perspectiveModel(model)) {
        return malformed(at, "camera_model \"" + model + "\" is not supported yet (" +
                                 (model == "OPENCV_FISHEYE" ? "a fisheye: " : "") +
                                 "holofuse reads perspective cameras: OPENCV, PINHOLE, "
                                 "SIMPLE_PINHOLE, or none given)");
      }
    }
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
    const std::string file_name = fs::path(path).filename().string();
    cam.name = split.empty() ? file_name : split + "/" + file_name;
    cam.split = split;
    cam.camera = c;
    frame.images.push_back(image);
    // nerfstudio names each frame's mask; otherwise masks/<image>.png if
    // there is one.
    if (f.contains("mask_path")) {
      if (!f["mask_path"].is_string()) return malformed(at, "\"mask_path\" is not a string");
      const fs::path mask = relativeTo(folder, f["mask_path"].get<std::string>());
      if (!fs::exists(mask))
        return malformed(at, "mask_path \"" + mask.string() + "\" does not exist");
      frame.masks.push_back(mask.string());
    } else {
      const fs::path mask =
          fs::path(folder) / "masks" / (fs::path(image).filename().string() + ".png");
      frame.masks.push_back(fs::exists(mask) ? std::optional<std::string>(mask.string())
                                             : std::nullopt);
    }
    d.cameras.push_back(std::move(cam));
  }
  return Status::ok();
}

}  // namespace

StatusOr<CaptureDescription> readNerfCapture(const std::string& folder) {
  CaptureDescription d;
  d.source = "nerf " + folder;
  CaptureFrame frame;
  const fs::path single = fs::path(folder) / "transforms.json";
  std::string where = single.string();
  if (fs::exists(single)) {
    HOLOFUSE_RETURN_IF_ERROR(readTransforms(folder, single, "", d, frame));
  } else {
    // The Blender layout: a file per split, those present read in order.
    bool any = false;
    for (const char* split : {"train", "val", "test"}) {
      const fs::path file = fs::path(folder) / ("transforms_" + std::string(split) + ".json");
      if (!fs::exists(file)) continue;
      any = true;
      HOLOFUSE_RETURN_IF_ERROR(readTransforms(folder, file, split, d, frame));
    }
    if (!any) {
      return Status(StatusCode::kIoError,
                    folder +
                        ": no transforms.json, nor the Blender layout's "
                        "transforms_train.json, transforms_val.json or transforms_test.json");
    }
    where = folder;
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
