// Calibrations given as matrices per image: one 3x4 projection matrix per
// file (the ETH course's .pa, .P, DTU's pos_NNN.txt), or Middlebury
// multi-view's *_par.txt, which lists K, R and t per image.
#include <algorithm>
#include <cctype>
#include <cmath>

#include "capture_parse.h"

namespace holofuse::dataset {

using namespace capture;

StatusOr<Camera> cameraFromProjection(const std::array<double, 12>& p, const std::string& where) {
  for (double v : p) {
    if (!std::isfinite(v))
      return malformed(where, "the projection matrix holds a value that is not finite");
  }
  glm::dvec3 m[3], p4;
  for (int row = 0; row < 3; ++row) {
    m[row] = glm::dvec3(p[4 * row], p[4 * row + 1], p[4 * row + 2]);
    p4[row] = p[4 * row + 3];
  }
  const double det = glm::dot(m[0], glm::cross(m[1], m[2]));
  const double scale = glm::length(m[0]) * glm::length(m[1]) * glm::length(m[2]);
  if (!(std::abs(det) > 1e-12 * scale) || !(scale > 0)) {
    return malformed(where, "the projection matrix's left 3x3 is singular (no camera centre)");
  }
  // P and -P project alike; K R = M with K's diagonal positive needs
  // det(M) > 0 for R to be a rotation rather than a reflection.
  if (det < 0) {
    for (auto& row : m) row = -row;
    p4 = -p4;
  }
  // RQ by Gram-Schmidt from the last row up: M's rows are K's rows
  // combining R's, and K upper triangular makes row 3 of M a multiple of
  // row 3 of R, row 2 a mix of rows 2 and 3, and so on.
  const double k33 = glm::length(m[2]);
  const glm::dvec3 r3 = m[2] / k33;
  const double k23 = glm::dot(m[1], r3);
  const glm::dvec3 v2 = m[1] - k23 * r3;
  const double k22 = glm::length(v2);
  const glm::dvec3 r2 = v2 / k22;
  const double k13 = glm::dot(m[0], r3), k12 = glm::dot(m[0], r2);
  const glm::dvec3 v1 = m[0] - k13 * r3 - k12 * r2;
  const double k11 = glm::length(v1);
  const glm::dvec3 r1 = v1 / k11;
  Camera c;
  c.fx = k11 / k33;
  c.skew = k12 / k33;
  c.cx = k13 / k33;
  c.fy = k22 / k33;
  c.cy = k23 / k33;
  for (int col = 0; col < 3; ++col) {
    c.rotation[col][0] = r1[col];
    c.rotation[col][1] = r2[col];
    c.rotation[col][2] = r3[col];
  }
  // p4 = K t, solved by back substitution (K upper triangular).
  const double tz = p4.z / k33;
  const double ty = (p4.y - k23 * tz) / k22;
  const double tx = (p4.x - k12 * ty - k13 * tz) / k11;
  c.translation = glm::dvec3(tx, ty, tz);
  return c;
}

namespace {

bool isProjectionFile(const fs::path& file) {
  const std::string ext = file.extension().string(), stem = file.stem().string();
  return ext == ".pa" || ext == ".P" || (ext == ".txt" && stem.rfind("pos_", 0) == 0);
}

// The 12 numbers of a projection matrix file; a leading CONTOUR line
// (PMVS's txt/ files) is skipped.
StatusOr<std::array<double, 12>> readProjection(const fs::path& file) {
  auto lines = contentLines(file);
  if (!lines.isOk()) return lines.status();
  std::array<double, 12> p{};
  size_t count = 0;
  for (const auto& [n, line] : *lines) {
    const std::string at = file.string() + ":" + std::to_string(n);
    const auto w = words(line);
    if (count == 0 && w.size() == 1 && w[0] == "CONTOUR") continue;
    for (const std::string& text : w) {
      double v = 0;
      if (!parseDouble(text, v)) return malformed(at, "'" + text + "' is not a finite number");
      if (count == 12) return malformed(at, "more than the 12 numbers of a 3x4 matrix");
      p[count++] = v;
    }
  }
  if (count != 12) {
    return malformed(file.string(),
                     "holds " + std::to_string(count) + " numbers, a 3x4 projection matrix 12");
  }
  return p;
}

// The first run of digits in a name, as a number; nullopt when it has none.
std::optional<unsigned long long> firstNumber(const std::string& name) {
  const auto digit = [](char ch) { return std::isdigit(static_cast<unsigned char>(ch)) != 0; };
  const auto begin = std::find_if(name.begin(), name.end(), digit);
  if (begin == name.end()) return std::nullopt;
  const auto end = std::find_if_not(begin, name.end(), digit);
  const std::string run(begin, end);
  return run.size() > 18 ? std::nullopt : std::optional(std::stoull(run));
}

// The image a projection file calibrates: the same stem, or for a name
// like pos_NNN the only image whose first number is NNN.
StatusOr<fs::path> imageForProjection(const fs::path& file, const std::vector<fs::path>& images) {
  const std::string stem = file.stem().string();
  for (const fs::path& image : images) {
    if (image.stem().string() == stem) return image;
  }
  const auto number = firstNumber(stem);
  std::vector<fs::path> numbered;
  if (number) {
    for (const fs::path& image : images) {
      if (firstNumber(image.stem().string()) == number) numbered.push_back(image);
    }
  }
  if (numbered.size() == 1) return numbered[0];
  if (numbered.empty()) {
    return malformed(file.string(),
                     "no image named " + stem + ".<png, jpg...> beside it or in images/");
  }
  std::string names;
  for (const fs::path& image : numbered)
    names += (names.empty() ? "" : ", ") + image.filename().string();
  return malformed(file.string(), "several images are numbered " + std::to_string(*number) + " (" +
                                      names + "); keep one per camera");
}

// Width and height from the image; the principal point moved to holofuse's
// pixel centres.
Status finishFromImage(CaptureCamera& cam, const fs::path& image, const std::string& where) {
  auto size = imageSize(image);
  if (!size.isOk()) return size.status();
  cam.camera.width = size->first;
  cam.camera.height = size->second;
  pixelCentresFromZero(cam.camera);
  return checkCamera(cam.camera, where);
}

}  // namespace

StatusOr<CaptureDescription> readProjectionCapture(const std::string& folder) {
  const fs::path root(folder);
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(root)) {
    if (entry.is_regular_file() && isProjectionFile(entry.path())) files.push_back(entry.path());
  }
  if (files.empty()) {
    return Status(StatusCode::kIoError,
                  folder + ": no projection matrix file (*.pa, *.P or pos_*.txt)");
  }
  std::vector<fs::path> images = imagesIn(root);
  for (const fs::path& image : imagesIn(root / "images")) images.push_back(image);
  CaptureDescription d;
  d.source = "projections " + folder;
  CaptureFrame frame;
  for (const fs::path& file : files) {
    auto p = readProjection(file);
    if (!p.isOk()) return p.status();
    auto camera = cameraFromProjection(*p, file.string());
    if (!camera.isOk()) return camera.status();
    auto image = imageForProjection(file, images);
    if (!image.isOk()) return image.status();
    CaptureCamera cam;
    cam.name = file.stem().string();
    cam.camera = *camera;
    HOLOFUSE_RETURN_IF_ERROR(finishFromImage(cam, *image, file.string()));
    frame.images.push_back(image->string());
    frame.masks.push_back(maskFor(*image, {root / "masks"}));
    d.cameras.push_back(std::move(cam));
  }
  d.frames.push_back(std::move(frame));
  numberCamerasByName(d);
  return d;
}

StatusOr<CaptureDescription> readMiddleburyCapture(const std::string& folder) {
  const fs::path root(folder);
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(root)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file() && name.size() > 8 &&
        name.compare(name.size() - 8, 8, "_par.txt") == 0) {
      files.push_back(entry.path());
    }
  }
  if (files.size() != 1) {
    return Status(StatusCode::kIoError,
                  folder + ": expected one Middlebury parameter file <name>_par.txt, found " +
                      std::to_string(files.size()));
  }
  const fs::path file = files[0];
  auto lines = contentLines(file);
  if (!lines.isOk()) return lines.status();
  if (lines->empty()) return malformed(file.string(), "is empty");
  double declared = 0;
  const auto first = words(lines->front().second);
  // A count beyond any file's lines is refused before it is converted (a
  // double past size_t's range does not convert; found by fuzzing).
  if (first.size() != 1 || !parseDouble(first[0], declared) || declared < 1 || declared > 1e9 ||
      declared != std::floor(declared)) {
    return malformed(file.string() + ":" + std::to_string(lines->front().first),
                     "expected the number of images");
  }
  if (static_cast<double>(lines->size() - 1) != declared) {
    return malformed(file.string(), "declares " + std::to_string(static_cast<size_t>(declared)) +
                                        " images and lists " + std::to_string(lines->size() - 1));
  }
  CaptureDescription d;
  d.source = "middlebury " + folder;
  CaptureFrame frame;
  for (size_t i = 1; i < lines->size(); ++i) {
    const auto& [n, line] = (*lines)[i];
    const std::string at = file.string() + ":" + std::to_string(n);
    const auto w = words(line);
    if (w.size() != 22)
      return malformed(at, "expected NAME k11..k33 r11..r33 t1 t2 t3 (22 values)");
    std::vector<double> v(21);
    for (size_t k = 0; k < 21; ++k) {
      if (!parseDouble(w[k + 1], v[k])) {
        return malformed(
            at, "value " + std::to_string(k + 2) + " '" + w[k + 1] + "' is not a finite number");
      }
    }
    CaptureCamera cam;
    cam.name = w[0];
    HOLOFUSE_RETURN_IF_ERROR(intrinsicsFromK({v.begin(), v.begin() + 9}, cam.camera, at));
    cam.camera.rotation = rowMajor({v.begin() + 9, v.begin() + 18});
    cam.camera.translation = glm::dvec3(v[18], v[19], v[20]);
    const fs::path image = root / cam.name;
    HOLOFUSE_RETURN_IF_ERROR(finishFromImage(cam, image, at));
    frame.images.push_back(image.string());
    frame.masks.push_back(maskFor(image, {root / "masks"}));
    d.cameras.push_back(std::move(cam));
  }
  d.frames.push_back(std::move(frame));
  numberCamerasByName(d);
  return d;
}

}  // namespace holofuse::dataset
