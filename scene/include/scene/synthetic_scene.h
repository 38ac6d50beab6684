// A deterministic animated subject with ground truth: a jointed figure
// (torso, head, swinging arms close to the body, walking legs) as a signed
// distance field, textured with high-frequency detail (stripes, a printed
// text panel, a face, checkered sleeves), seen by cameras with different
// colour gains in front of a known backdrop (or in a studio: a floor that
// takes its shadow, a prop, lights that flicker). Everything is a function of
// the frame id and the seed, so tests can ask for the truth of any frame.
#pragma once

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "image/image.h"

namespace holofuse::scene {

// The most sensor noise a scene takes (--noise, scene::sceneFlags()).
inline constexpr double kMaxNoise = 64;

struct SceneOptions {
  uint64_t seed = 1;
  double frames_per_second = 10.0;  // scene time = frame id / this
  double noise_amplitude = 2.0;     // sensor noise, grey levels (0..kMaxNoise)
  double gain_spread = 1.0;         // scales how far each camera's colour gain is from 1
  double specular = 0.0;            // strength of a white specular highlight (view dependent)
  double motion_speed = 1.0;        // scales the animation's clock
  // A studio instead of a far backdrop: a tiled floor that takes the
  // subject's shadow from the light, and a static prop (a stand) outside
  // the capture volume that some cameras see, in the plate as well.
  bool studio = false;
  // In a studio, a checkerboard on a post set down after the plate was
  // taken: in every frame, not in the plate. No camera alone can tell it
  // from the subject; the rig can, as it stands outside the capture volume.
  bool late_prop = false;
  // The lights' gain changes from frame to frame by up to this fraction
  // (mains flicker beating with the shutter); the plate is taken at gain 1.
  double flicker = 0.0;
};

// Deterministic hash of x to [0, 1): the scene's only source of "randomness".
double hashToUnitInterval(uint64_t x);

struct RenderedView {
  Image8 color;  // RGB
  Image8 mask;   // 255 where the subject is, 0 elsewhere (the truth)
  // Studio scenes: 255 where the subject's shadow falls on the floor the
  // camera sees, 0 elsewhere; empty otherwise.
  Image8 shadow;
};

class SyntheticScene {
 public:
  friend class CameraRenderer;

  explicit SyntheticScene(SceneOptions options = {});

  // Signed distance (metres, negative inside) of the subject at scene time t.
  double signedDistance(const glm::dvec3& p, double t) const;
  double timeOf(uint64_t frame_id) const {
    return options_.motion_speed * static_cast<double>(frame_id) / options_.frames_per_second;
  }
  const SceneOptions& options() const { return options_; }

  // The ring of cameras the synthetic pods use.
  static std::vector<Camera> cameraRig(int count, uint32_t width, uint32_t height);
  // A camera on the rig's ring at `degrees` around the vertical axis (pod i
  // of n sits at 360 i / n): novel views with a true image.
  static Camera ringPose(double degrees, uint32_t id, uint32_t width, uint32_t height);
  // Per-camera colour gain (white balance differs between pods).
  glm::dvec3 cameraGain(uint32_t camera_id) const;
  // The lights' gain at a frame: 1, or within 1 +- flicker.
  double lightGain(uint64_t frame_id) const;

  // The true image and mask of a camera at a frame (with sensor noise).
  RenderedView render(const Camera& camera, uint64_t frame_id) const;
  // The empty studio as the camera sees it (noise free), for segmentation.
  Image8 backgroundPlate(const Camera& camera) const;
  // The true surface at a frame, by marching cubes at the given spacing.
  Mesh truthMesh(uint64_t frame_id, double spacing = 0.01) const;
  // Axis-aligned box that holds the subject at any time.
  static void subjectBounds(glm::dvec3& lo, glm::dvec3& hi);

 private:
  struct Pose;
  Pose poseAt(double t) const;
  double distance(const glm::dvec3& p, const Pose& pose, int* part) const;
  glm::dvec3 albedo(const glm::dvec3& p, const Pose& pose, int part) const;
  glm::dvec3 backdrop(const glm::dvec3& ray_dir) const;
  // What a ray from origin meets besides the subject, the same every
  // frame: in a studio the floor or a prop (t: how far along the unit
  // ray; on the floor, where), else the far backdrop (t infinite). The
  // plate is taken without the late prop.
  struct Surroundings {
    glm::dvec3 color{0.0};
    double t = 0;
    bool floor = false;
    glm::dvec3 point{0.0};
  };
  Surroundings surroundings(const glm::dvec3& origin, const glm::dvec3& dir, bool late_prop) const;
  // Whether the subject in this pose stands between floor point p and the
  // light; the floor there is then lit by the ambient term alone.
  static bool inSubjectShadow(const glm::dvec3& p, const Pose& pose);
  // The colour of a pixel that misses the subject or sees it behind the
  // surroundings: their colour, darkened where the subject's shadow falls.
  glm::dvec3 surroundingsColor(const Surroundings& around, const Pose& pose, bool* shadowed) const;
  // The lit colour of surface point p of a part, normal n, seen along dir.
  glm::dvec3 shade(const glm::dvec3& p, const glm::dvec3& n, const glm::dvec3& dir,
                   const Pose& pose, int part, const glm::dvec3& gain) const;
  // Pixel (x, y) of view: color with the sensor's noise, and the mask.
  void writePixel(RenderedView& view, const Camera& camera, uint64_t frame_id, uint32_t x,
                  uint32_t y, const glm::dvec3& color, bool hit, bool shadowed) const;
  RenderedView emptyView(const Camera& camera) const;
  // Pixels a part can cover (pixel centres), with a margin; the whole
  // image when an end of it is behind the camera.
  struct PartRect {
    double x0, y0, x1, y1;
  };
  static PartRect projectedRect(const Camera& camera, const Pose& pose, int part);

  SceneOptions options_;
};

// The live pods' renderer of one camera: the same picture as
// SyntheticScene::render (what sphere tracing stops on, in closed form),
// several times faster. What depends only on the camera (each pixel's ray
// and backdrop colour) is computed once; each frame, every ray inside a
// part's projected rectangle is intersected with that part's capsule
// grown by the tracer's stopping distance, so the first entry is where the
// tracer would stop, without stepping. render() stays the truth eval
// judges against; how far the two differ is tested and measured
// (bench_pod).
class CameraRenderer {
 public:
  CameraRenderer(const SyntheticScene& scene, const Camera& camera);
  RenderedView render(uint64_t frame_id) const;
  const Camera& camera() const { return camera_; }

 private:
  const SyntheticScene& scene_;
  Camera camera_;
  std::vector<glm::dvec3> rays_;                      // unit, world, per pixel
  std::vector<SyntheticScene::Surroundings> around_;  // what each pixel sees but the subject
};

}  // namespace holofuse::scene
