#include "geometry/camera.h"

#include <cmath>
#include <numbers>

namespace holofuse {

glm::dvec3 Camera::center() const { return -glm::transpose(rotation) * translation; }

glm::dvec3 Camera::forward() const { return glm::transpose(rotation) * glm::dvec3(0, 0, 1); }

std::optional<glm::dvec3> Camera::project(const glm::dvec3& world) const {
  const glm::dvec3 c = toCamera(world);
  if (!(c.z > 1e-9)) return std::nullopt;
  double x = c.x / c.z;
  double y = c.y / c.z;
  if (!distortion.empty()) {
    const double k1 = distortion.size() > 0 ? distortion[0] : 0;
    const double k2 = distortion.size() > 1 ? distortion[1] : 0;
    const double p1 = distortion.size() > 2 ? distortion[2] : 0;
    const double p2 = distortion.size() > 3 ? distortion[3] : 0;
    const double k3 = distortion.size() > 4 ? distortion[4] : 0;
    const double r2 = x * x + y * y;
    const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
    const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
    x = xd;
    y = yd;
  }
  return glm::dvec3(fx * x + skew * y + cx, fy * y + cy, c.z);
}

glm::dvec3 Camera::rayDirection(double u, double v) const {
  const double y = (v - cy) / fy;
  const double x = (u - cx - skew * y) / fx;
  return glm::normalize(glm::transpose(rotation) * glm::dvec3(x, y, 1.0));
}

Camera lookAtCamera(uint32_t id, const glm::dvec3& eye, const glm::dvec3& target,
                    const glm::dvec3& up, uint32_t width, uint32_t height, double fov_x_degrees) {
  Camera cam;
  cam.id = id;
  cam.width = width;
  cam.height = height;
  const double f = 0.5 * width / std::tan(0.5 * fov_x_degrees * std::numbers::pi / 180.0);
  cam.fx = f;
  cam.fy = f;
  cam.cx = 0.5 * width;
  cam.cy = 0.5 * height;
  const glm::dvec3 z = glm::normalize(target - eye);
  const glm::dvec3 x = glm::normalize(glm::cross(z, up));  // right
  const glm::dvec3 y = glm::cross(z, x);                   // down
  // Rows of the world-to-camera rotation are the camera axes.
  cam.rotation = glm::transpose(glm::dmat3(x, y, z));
  cam.translation = -(cam.rotation * eye);
  return cam;
}

std::vector<Camera> ringCameras(int count, double radius, double height, const glm::dvec3& target,
                                uint32_t width, uint32_t height_px, double fov_x_degrees) {
  std::vector<Camera> cameras;
  for (int i = 0; i < count; ++i) {
    const double a = 2.0 * std::numbers::pi * i / count;
    const glm::dvec3 eye(radius * std::sin(a), height, radius * std::cos(a));
    cameras.push_back(lookAtCamera(static_cast<uint32_t>(i), eye, target, glm::dvec3(0, 1, 0),
                                   width, height_px, fov_x_degrees));
  }
  return cameras;
}

protocol::Calibration toCalibration(const Camera& camera) {
  protocol::Calibration m;
  m.camera_id = camera.id;
  m.width = camera.width;
  m.height = camera.height;
  m.fx = camera.fx;
  m.fy = camera.fy;
  m.cx = camera.cx;
  m.cy = camera.cy;
  m.skew = camera.skew;
  m.distortion = camera.distortion;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      m.rotation[r * 3 + c] = camera.rotation[c][r];  // glm is column major
    m.translation[r] = camera.translation[r];
  }
  return m;
}

Camera fromCalibration(const protocol::Calibration& m) {
  Camera camera;
  camera.id = m.camera_id;
  camera.width = m.width;
  camera.height = m.height;
  camera.fx = m.fx;
  camera.fy = m.fy;
  camera.cx = m.cx;
  camera.cy = m.cy;
  camera.skew = m.skew;
  camera.distortion = m.distortion;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) camera.rotation[c][r] = m.rotation[r * 3 + c];
    camera.translation[r] = m.translation[r];
  }
  return camera;
}

}  // namespace holofuse
