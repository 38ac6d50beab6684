#include "dataset/capture_formats.h"

#include <algorithm>
#include <cctype>
#include <map>

#include "capture_parse.h"

namespace holofuse::dataset {

using namespace capture;

namespace {

struct NamedFormat {
  const char* name;
  CaptureFormat format;
  StatusOr<CaptureDescription> (*read)(const std::string& folder);
};

constexpr NamedFormat kFormats[] = {
    {"holofuse", CaptureFormat::kHolofuse, readHolofuseCapture},
    {"colmap", CaptureFormat::kColmap, readColmapCapture},
    {"nerf", CaptureFormat::kNerf, readNerfCapture},
    {"opencv", CaptureFormat::kOpencv, readOpencvCapture},
    {"projections", CaptureFormat::kProjections, readProjectionCapture},
    {"middlebury", CaptureFormat::kMiddlebury, readMiddleburyCapture},
    {"panoptic", CaptureFormat::kPanoptic, readPanopticCapture},
};

}  // namespace

std::optional<CaptureFormat> captureFormatFromName(const std::string& name) {
  for (const NamedFormat& f : kFormats) {
    if (name == f.name) return f.format;
  }
  return std::nullopt;
}

const char* captureFormatNames() {
  return "holofuse, colmap, nerf, opencv, projections, middlebury, panoptic";
}

bool isVideoFile(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return ext == ".mp4" || ext == ".avi" || ext == ".mkv" || ext == ".mov" || ext == ".webm";
}

std::string videoFrameName(const std::string& video, size_t index) {
  return video + "#" + std::to_string(index);
}

std::optional<VideoFrameName> parseVideoFrameName(const std::string& name) {
  const size_t hash = name.rfind('#');
  if (hash == std::string::npos || hash + 1 == name.size()) return std::nullopt;
  const std::string digits = name.substr(hash + 1);
  if (digits.size() > 12 ||
      !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }))
    return std::nullopt;
  VideoFrameName out{name.substr(0, hash), static_cast<size_t>(std::stoull(digits))};
  if (!isVideoFile(out.video)) return std::nullopt;
  return out;
}

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
  if (!root.is_object() || !root.contains("format") || root["format"] != "holofuse-capture") {
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
  std::vector<CameraImages> videos;
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
    HOLOFUSE_RETURN_IF_ERROR(intrinsicsFromK(*k, cam.camera, at + ".K"));
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
    for (const char* key : {"video", "mask_video"}) {
      if (c.contains(key) && !c[key].is_string())
        return malformed(at + "." + key, "expected a file name");
    }
    if (c.contains("video")) {
      const std::string video = relativeTo(folder, c["video"].get<std::string>());
      const std::optional<std::string> mask_video =
          c.contains("mask_video")
              ? std::optional(relativeTo(folder, c["mask_video"].get<std::string>()))
              : std::nullopt;
      videos.push_back(videoImages(video, mask_video));
      if (videos.back().images.empty()) return malformed(at + ".video", video + ": cannot read");
    }
    by_name[cam.name] = i;
    d.cameras.push_back(std::move(cam));
  }
  // One video per camera instead of frames: paired by their timestamps.
  if (!videos.empty()) {
    if (videos.size() != d.cameras.size() || root.contains("frames")) {
      return malformed(where,
                       "either every camera names a \"video\" and there are no "
                       "\"frames\", or none does (" +
                           std::to_string(videos.size()) + " of " +
                           std::to_string(d.cameras.size()) + " do)");
    }
    auto matched = matchFrames(d.cameras, videos, where);
    if (!matched.isOk()) return matched.status();
    if (!root.contains("fps") && matched->fps) d.fps = *matched->fps;
    d.frames = std::move(matched->frames);
    d.frame_matching = std::move(matched->matching);
    numberCamerasByName(d);
    return d;
  }
  // Cameras alone: a rig's calibration, which live camera pods read.
  if (!root.contains("frames")) {
    numberCamerasByName(d);
    return d;
  }
  if (!root["frames"].is_array() || root["frames"].empty()) {
    return malformed(where, "expected a non-empty \"frames\" array (or a \"video\" per camera)");
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

StatusOr<CaptureDescription> readCapture(const std::string& folder, CaptureFormat format) {
  if (!fs::is_directory(folder)) return Status(StatusCode::kIoError, folder + ": not a folder");
  for (const NamedFormat& f : kFormats) {
    if (f.format != format) continue;
    // The readers check the types they read and name the path of a wrong
    // one; a value of a type they did not expect where they did not check
    // (a non-string "format", found by fuzzing) still becomes an error
    // naming the folder, never an exception out of the import.
    try {
      return f.read(folder);
    } catch (const nlohmann::json::exception& e) {
      return malformed(folder, std::string("a JSON value of the wrong type (") + e.what() + ")");
    } catch (const std::filesystem::filesystem_error& e) {
      return Status(StatusCode::kIoError, folder + ": " + e.what());
    }
  }
  return Status(StatusCode::kMalformed, "unknown capture format");
}

}  // namespace holofuse::dataset
