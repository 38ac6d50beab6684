// Pinhole camera with OpenCV conventions (x right, y down, z forward) and
// its conversion to and from the wire Calibration message.
#pragma once

#include <glm/glm.hpp>
#include <optional>
#include <vector>

#include "protocol/messages.h"

namespace holofuse {

struct Camera {
  uint32_t id = 0;
  uint32_t width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0, skew = 0;
  std::vector<double> distortion;  // k1 k2 p1 p2 k3; empty means none
  glm::dmat3 rotation{1.0};        // world to camera
  glm::dvec3 translation{0.0};     // world to camera

  // Camera centre in world coordinates.
  glm::dvec3 center() const;
  // Unit optical axis (camera +z) in world coordinates.
  glm::dvec3 forward() const;
  // World point to camera coordinates.
  glm::dvec3 toCamera(const glm::dvec3& world) const { return rotation * world + translation; }
  // Pixel (x right, y down, pixel centres at .5) and depth of a world point,
  // or nothing behind the camera. Distortion is applied when present.
  std::optional<glm::dvec3> project(const glm::dvec3& world) const;
  // Unit ray direction in world coordinates through pixel (u, v), ignoring
  // distortion (synthetic cameras have none).
  glm::dvec3 rayDirection(double u, double v) const;
};

// A camera at eye looking at target with world up, image w x h, horizontal
// field of view in degrees.
Camera lookAtCamera(uint32_t id, const glm::dvec3& eye, const glm::dvec3& target,
                    const glm::dvec3& up, uint32_t width, uint32_t height, double fov_x_degrees);

// N cameras evenly on a horizontal ring around target.
std::vector<Camera> ringCameras(int count, double radius, double height, const glm::dvec3& target,
                                uint32_t width, uint32_t height_px, double fov_x_degrees);

protocol::Calibration toCalibration(const Camera& camera);
Camera fromCalibration(const protocol::Calibration& calibration);

}  // namespace holofuse
