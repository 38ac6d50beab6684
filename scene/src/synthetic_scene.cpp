#include "scene/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "geometry/marching_cubes.h"

namespace holofuse::scene {
namespace {

constexpr double kPi = std::numbers::pi;

enum Part {
  kTorso,
  kHead,
  kNeck,
  kUpperArmL,
  kForearmL,
  kUpperArmR,
  kForearmR,
  kThighL,
  kShinL,
  kThighR,
  kShinR,
  kPartCount
};

struct Capsule {
  glm::dvec3 a, b;
  double radius;
};

double capsuleDistance(const glm::dvec3& p, const Capsule& c) {
  const glm::dvec3 pa = p - c.a, ba = c.b - c.a;
  const double len2 = glm::dot(ba, ba);
  const double h = len2 > 0 ? std::clamp(glm::dot(pa, ba) / len2, 0.0, 1.0) : 0.0;
  return glm::length(pa - ba * h) - c.radius;
}

// Where the ray o + t d (d of any length) first enters capsule c, or a
// negative t when it misses it or starts inside: the cylinder's side where
// the entry falls between the ends, else the nearer end's sphere.
double capsuleEntry(const glm::dvec3& o, const glm::dvec3& d, const Capsule& c) {
  const glm::dvec3 ba = c.b - c.a, oa = o - c.a;
  const double baba = glm::dot(ba, ba), bard = glm::dot(ba, d), baoa = glm::dot(ba, oa);
  const double dd = glm::dot(d, d), rdoa = glm::dot(d, oa), oaoa = glm::dot(oa, oa);
  const double r2 = c.radius * c.radius;
  double y = -1;  // along the axis, in units of 1 / |ba|^2, where the side is entered
  if (baba > 0) {
    const double a = dd * baba - bard * bard;
    const double b = baba * rdoa - baoa * bard;
    const double k = baba * oaoa - baoa * baoa - r2 * baba;
    const double h = b * b - a * k;
    if (h < 0) return -1;  // misses the infinite cylinder, so the capsule too
    if (a > 0) {
      const double t = (-b - std::sqrt(h)) / a;
      y = baoa + t * bard;
      if (y > 0 && y < baba) return t;
    }
  }
  const glm::dvec3 oc = y <= 0 ? oa : o - c.b;
  const double b = glm::dot(d, oc), k = glm::dot(oc, oc) - r2;
  const double h = b * b - dd * k;
  if (h < 0 || k < 0) return -1;
  return (-b - std::sqrt(h)) / dd;
}

int64_t cell(double v, double size) { return static_cast<int64_t>(std::floor(v / size)); }

constexpr double kTorsoDepthScale = 1.45;  // the torso is flatter front to back
const glm::dvec3 kLight = glm::normalize(glm::dvec3(0.3, 0.8, 0.5));
// Lambert's law with an ambient term: a surface facing away from the light,
// or in a shadow, keeps 35% of its colour.
constexpr double kAmbient = 0.35;

// The studio (SceneOptions::studio): the floor is y = 0 out to kFloorRadius;
// the prop is a stand, an upright box, behind the pods' ring between two of
// them (at 202.5 degrees, 3.4 m out): the pods across the room see it
// beside the subject, and it never hides the subject from any of them.
constexpr double kFloorRadius = 6.0;
const glm::dvec3 kPropMin(-1.45, 0.0, -3.29), kPropMax(-1.15, 1.3, -2.99);
// The late prop (SceneOptions::late_prop): a checkerboard on a post, the
// stand's place turned by 90 degrees (112.5 degrees, 3.4 m out), its board
// facing the room.
const glm::dvec3 kBoardMin(3.05, 0.7, -1.65), kBoardMax(3.1, 1.3, -0.95);
const glm::dvec3 kPostMin(3.04, 0.0, -1.33), kPostMax(3.1, 0.7, -1.27);

// Where the ray o + t d (d unit) enters the box [lo, hi], and the face's
// normal; a negative t when it misses it or starts inside.
double boxEntry(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& lo,
                const glm::dvec3& hi, glm::dvec3* normal) {
  double t0 = -std::numeric_limits<double>::infinity(), t1 = -t0;
  int axis = -1;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (o[k] < lo[k] || o[k] > hi[k]) return -1;
      continue;
    }
    double a = (lo[k] - o[k]) / d[k], b = (hi[k] - o[k]) / d[k];
    if (a > b) std::swap(a, b);
    if (a > t0) {
      t0 = a;
      axis = k;
    }
    t1 = std::min(t1, b);
  }
  if (t0 > t1 || t0 <= 0 || axis < 0) return -1;
  if (normal != nullptr) {
    *normal = glm::dvec3(0.0);
    (*normal)[axis] = d[axis] > 0 ? -1.0 : 1.0;
  }
  return t0;
}

glm::dvec3 floorAlbedo(const glm::dvec3& p) {
  // 0.5 m tiles of two greenish greys (the colour a real studio floor
  // often has under its lights), with a thin darker grout.
  const double u = p.x / 0.5, v = p.z / 0.5;
  const double fu = u - std::floor(u), fv = v - std::floor(v);
  if (fu < 0.03 || fv < 0.03) return glm::dvec3(0.24, 0.27, 0.23);
  return ((cell(p.x, 0.5) + cell(p.z, 0.5)) & 1) ? glm::dvec3(0.40, 0.47, 0.37)
                                                 : glm::dvec3(0.34, 0.41, 0.32);
}

glm::dvec3 propAlbedo(const glm::dvec3& p) {
  // A grey stand with a white band, like a light stand's clamp.
  if (p.y > 0.62 && p.y < 0.7) return glm::dvec3(0.85, 0.85, 0.82);
  return glm::dvec3(0.22, 0.23, 0.26);
}

glm::dvec3 boardAlbedo(const glm::dvec3& p) {
  // Calibration squares of 0.1 m on the board; the post dark grey.
  if (p.y < kBoardMin.y) return glm::dvec3(0.2, 0.2, 0.2);
  return ((cell(p.y, 0.1) + cell(p.z, 0.1)) & 1) ? glm::dvec3(0.08, 0.08, 0.08)
                                                 : glm::dvec3(0.85, 0.85, 0.85);
}

// The nearest of the props a ray o + t d meets: its t (negative when none),
// normal and albedo.
struct PropHit {
  double t = -1;
  glm::dvec3 normal{0.0}, albedo{0.0};
};

PropHit nearestProp(const glm::dvec3& o, const glm::dvec3& d, bool late_prop) {
  PropHit hit;
  auto consider = [&](const glm::dvec3& lo, const glm::dvec3& hi, auto albedo) {
    glm::dvec3 normal;
    const double t = boxEntry(o, d, lo, hi, &normal);
    if (t > 0 && (hit.t < 0 || t < hit.t)) hit = {t, normal, albedo(o + t * d)};
  };
  consider(kPropMin, kPropMax, propAlbedo);
  if (late_prop) {
    consider(kBoardMin, kBoardMax, boardAlbedo);
    consider(kPostMin, kPostMax, boardAlbedo);
  }
  return hit;
}

}  // namespace

double hashToUnitInterval(uint64_t x) {
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdull;
  x ^= x >> 33;
  x *= 0xc4ceb9fe1a85ec53ull;
  x ^= x >> 33;
  return static_cast<double>(x >> 11) * (1.0 / 9007199254740992.0);
}

struct SyntheticScene::Pose {
  glm::dmat3 body_to_world{1.0};
  glm::dvec3 body_origin{0.0};
  std::array<Capsule, kPartCount> parts{};
  glm::dvec3 toBody(const glm::dvec3& p) const {
    return glm::transpose(body_to_world) * (p - body_origin);
  }
};

SyntheticScene::SyntheticScene(SceneOptions options) : options_(options) {}

SyntheticScene::Pose SyntheticScene::poseAt(double t) const {
  Pose pose;
  // A per-seed phase so different seeds give different motion.
  const double phase = hashToUnitInterval(options_.seed) * 2 * kPi;
  const double yaw = 0.35 * std::sin(0.4 * t + phase);
  const double c = std::cos(yaw), s = std::sin(yaw);
  pose.body_to_world = glm::dmat3(glm::dvec3(c, 0, -s), glm::dvec3(0, 1, 0), glm::dvec3(s, 0, c));
  pose.body_origin = glm::dvec3(0.08 * std::sin(0.6 * t + phase), 0, 0);
  auto world = [&](const glm::dvec3& local) {
    return pose.body_origin + pose.body_to_world * local;
  };

  pose.parts[kTorso] = {glm::dvec3(0, 0.88, 0), glm::dvec3(0, 1.28, 0), 0.16};
  pose.parts[kHead] = {glm::dvec3(0, 1.56, 0), glm::dvec3(0, 1.56, 0), 0.115};
  pose.parts[kNeck] = {glm::dvec3(0, 1.3, 0), glm::dvec3(0, 1.47, 0), 0.055};
  for (int side = 0; side < 2; ++side) {
    const double sign = side == 0 ? -1.0 : 1.0;
    // Arms swing forward and back close to the body: the gap between arm
    // and torso is a concavity no silhouette can carve.
    const double swing = 0.55 * std::sin(1.5 * t + side * kPi + phase);
    const double bend = 0.5 + 0.4 * std::sin(1.5 * t + side * kPi + 0.5 + phase);
    const double abduct = 0.14;
    const glm::dvec3 shoulder(sign * 0.235, 1.36, 0);
    const glm::dvec3 upper(sign * std::sin(abduct), -std::cos(abduct) * std::cos(swing),
                           std::cos(abduct) * std::sin(swing));
    const glm::dvec3 lower(sign * std::sin(abduct), -std::cos(abduct) * std::cos(swing + bend),
                           std::cos(abduct) * std::sin(swing + bend));
    const glm::dvec3 elbow = shoulder + 0.28 * upper;
    const glm::dvec3 hand = elbow + 0.26 * lower;
    pose.parts[side == 0 ? kUpperArmL : kUpperArmR] = {shoulder, elbow, 0.05};
    pose.parts[side == 0 ? kForearmL : kForearmR] = {elbow, hand, 0.042};

    const double stride = 0.32 * std::sin(1.5 * t + (1 - side) * kPi + phase);
    const double knee_bend = 0.25 * (1 + std::sin(1.5 * t + (1 - side) * kPi + phase + 1.0));
    const glm::dvec3 hip(sign * 0.09, 0.86, 0);
    const glm::dvec3 thigh(0, -std::cos(stride), std::sin(stride));
    const glm::dvec3 shin(0, -std::cos(stride - knee_bend), std::sin(stride - knee_bend));
    const glm::dvec3 knee = hip + 0.41 * thigh;
    const glm::dvec3 foot = knee + 0.41 * shin;
    pose.parts[side == 0 ? kThighL : kThighR] = {hip, knee, 0.072};
    pose.parts[side == 0 ? kShinL : kShinR] = {knee, foot, 0.058};
  }
  for (auto& part : pose.parts) {
    if (&part == &pose.parts[kTorso]) continue;  // the torso is evaluated in body space
    part.a = world(part.a);
    part.b = world(part.b);
  }
  return pose;
}

double SyntheticScene::distance(const glm::dvec3& p, const Pose& pose, int* part) const {
  // Torso in body space, flattened front to back; dividing by the largest
  // scale keeps the value a lower bound of the true distance (safe for
  // sphere tracing) with the exact sign.
  glm::dvec3 q = pose.toBody(p);
  q.z *= kTorsoDepthScale;
  double best = capsuleDistance(q, pose.parts[kTorso]) / kTorsoDepthScale;
  int best_part = kTorso;
  for (int i = 1; i < kPartCount; ++i) {
    const double d = capsuleDistance(p, pose.parts[i]);
    if (d < best) {
      best = d;
      best_part = i;
    }
  }
  if (part != nullptr) *part = best_part;
  return best;
}

double SyntheticScene::signedDistance(const glm::dvec3& p, double t) const {
  return distance(p, poseAt(t), nullptr);
}

glm::dvec3 SyntheticScene::albedo(const glm::dvec3& p, const Pose& pose, int part) const {
  const glm::dvec3 b = pose.toBody(p);
  const glm::dvec3 skin(0.88, 0.68, 0.55);
  switch (part) {
    case kTorso: {
      // A printed panel of pseudo-text on the chest: 5x7-cell glyphs of
      // 1.1 cm cells, the finest detail of the scene.
      if (b.z > 0 && std::abs(b.x) < 0.11 && b.y > 1.02 && b.y < 1.2) {
        const double cell_size = 0.011;
        const int64_t cx = cell(b.x + 0.11, cell_size), cy = cell(1.2 - b.y, cell_size);
        const int64_t gx = cx / 6, gy = cy / 8, ix = cx % 6, iy = cy % 8;
        if (ix < 5 && iy < 7 &&
            hashToUnitInterval(options_.seed * 7919 + gx * 131 + gy * 977 + ix * 17 + iy) > 0.55) {
          return glm::dvec3(0.06, 0.06, 0.08);
        }
        return glm::dvec3(0.96, 0.95, 0.9);
      }
      const bool stripe = (cell(b.y, 0.025) & 1) != 0;
      return stripe ? glm::dvec3(0.82, 0.14, 0.16) : glm::dvec3(0.95, 0.9, 0.78);
    }
    case kHead: {
      const glm::dvec3 h = b - glm::dvec3(0, 1.56, 0);
      if (h.y > 0.045 || (h.z < -0.02 && h.y > -0.03)) return glm::dvec3(0.3, 0.18, 0.08);  // hair
      if (h.z > 0.05) {
        for (double ex : {-0.04, 0.04}) {
          if (std::hypot(h.x - ex, h.y - 0.015) < 0.017)
            return glm::dvec3(0.08, 0.08, 0.12);  // eyes
        }
        if (std::abs(h.x) < 0.04 && h.y > -0.06 && h.y < -0.042) return glm::dvec3(0.62, 0.1, 0.12);
        if (std::abs(h.x) < 0.012 && h.y > -0.03 && h.y < 0.0) return glm::dvec3(0.75, 0.5, 0.42);
      }
      return skin;
    }
    case kNeck:
      return skin;
    default: {
      // Limbs: a checker in the limb's own frame (along the axis x around
      // it), so the texture moves with the limb.
      const Capsule& c = pose.parts[part];
      const glm::dvec3 axis = glm::normalize(c.b - c.a);
      const glm::dvec3 side = pose.body_to_world * glm::dvec3(1, 0, 0);
      glm::dvec3 ref = side - axis * glm::dot(side, axis);
      ref = glm::length(ref) > 1e-9 ? glm::normalize(ref) : glm::dvec3(0, 0, 1);
      const glm::dvec3 ref2 = glm::cross(axis, ref);
      const glm::dvec3 rel = p - c.a;
      const double along = glm::dot(rel, axis);
      const double angle = std::atan2(glm::dot(rel, ref2), glm::dot(rel, ref));
      const int64_t checker = cell(along, 0.03) + cell(angle + kPi, kPi / 6);
      const bool arm = part <= kForearmR;
      if (arm) return (checker & 1) ? glm::dvec3(0.95, 0.8, 0.1) : glm::dvec3(0.12, 0.3, 0.8);
      return (cell(angle + kPi, kPi / 10) & 1) ? glm::dvec3(0.16, 0.24, 0.5)
                                               : glm::dvec3(0.3, 0.38, 0.62);
    }
  }
}

glm::dvec3 SyntheticScene::backdrop(const glm::dvec3& d) const {
  const double around = std::atan2(d.x, d.z);
  return glm::dvec3(0.2, 0.33, 0.25) + 0.05 * d.y + 0.025 * std::sin(5 * around);
}

namespace {
constexpr double kRingRadius = 2.6, kRingHeight = 1.0, kRingFovDegrees = 48.0;
const glm::dvec3 kRingTarget(0, 0.85, 0);
}  // namespace

std::vector<Camera> SyntheticScene::cameraRig(int count, uint32_t width, uint32_t height) {
  return ringCameras(count, kRingRadius, kRingHeight, kRingTarget, width, height, kRingFovDegrees);
}

Camera SyntheticScene::ringPose(double degrees, uint32_t id, uint32_t width, uint32_t height) {
  const double a = degrees * std::numbers::pi / 180.0;
  const glm::dvec3 eye(kRingRadius * std::sin(a), kRingHeight, kRingRadius * std::cos(a));
  return lookAtCamera(id, eye, kRingTarget, glm::dvec3(0, 1, 0), width, height, kRingFovDegrees);
}

glm::dvec3 SyntheticScene::cameraGain(uint32_t id) const {
  const double i = id + 0.37 * static_cast<double>(options_.seed % 7);
  const double k = options_.gain_spread;
  return glm::dvec3(1 + k * 0.07 * std::sin(1.3 * i), 1 + k * 0.05 * std::sin(2.1 * i + 1),
                    1 + k * 0.07 * std::sin(0.7 * i + 2));
}

double SyntheticScene::lightGain(uint64_t frame_id) const {
  if (options_.flicker <= 0) return 1.0;
  return 1.0 + options_.flicker * (2 * hashToUnitInterval(options_.seed * 104729 + frame_id) - 1);
}

SyntheticScene::Surroundings SyntheticScene::surroundings(const glm::dvec3& origin,
                                                          const glm::dvec3& dir,
                                                          bool late_prop) const {
  Surroundings around;
  around.t = std::numeric_limits<double>::infinity();
  around.color = backdrop(dir);
  if (!options_.studio) return around;
  const PropHit prop = nearestProp(origin, dir, late_prop);
  if (dir.y < 0) {
    const double t = -origin.y / dir.y;
    const glm::dvec3 p = origin + t * dir;
    if (t > 0 && std::hypot(p.x, p.z) < kFloorRadius && (prop.t < 0 || t < prop.t)) {
      around.t = t;
      around.floor = true;
      around.point = p;
      // The props' own shadows are part of the studio (the stand's of the
      // plate as well).
      const bool prop_shadow = nearestProp(p, kLight, late_prop).t > 0;
      around.color =
          floorAlbedo(p) * (prop_shadow ? kAmbient : kAmbient + (1 - kAmbient) * kLight.y);
      return around;
    }
  }
  if (prop.t > 0) {
    around.t = prop.t;
    around.color =
        prop.albedo * (kAmbient + (1 - kAmbient) * std::max(0.0, glm::dot(prop.normal, kLight)));
  }
  return around;
}

bool SyntheticScene::inSubjectShadow(const glm::dvec3& p, const Pose& pose) {
  // The torso's capsule lives in body space with its depth stretched.
  const glm::dvec3 stretch(1, 1, kTorsoDepthScale);
  const glm::dmat3 to_body = glm::transpose(pose.body_to_world);
  const glm::dvec3 body_p = stretch * (to_body * (p - pose.body_origin));
  const glm::dvec3 body_l = stretch * (to_body * kLight);
  for (int i = 0; i < kPartCount; ++i) {
    const double t = i == kTorso ? capsuleEntry(body_p, body_l, pose.parts[i])
                                 : capsuleEntry(p, kLight, pose.parts[i]);
    if (t > 0) return true;
  }
  return false;
}

glm::dvec3 SyntheticScene::surroundingsColor(const Surroundings& around, const Pose& pose,
                                             bool* shadowed) const {
  *shadowed = around.floor && inSubjectShadow(around.point, pose);
  if (!*shadowed) return around.color;
  // Lit by the ambient term alone: darker, the same chromaticity.
  return floorAlbedo(around.point) * kAmbient;
}

void SyntheticScene::subjectBounds(glm::dvec3& lo, glm::dvec3& hi) {
  lo = glm::dvec3(-0.75, -0.08, -0.75);
  hi = glm::dvec3(0.75, 1.75, 0.75);
}

Image8 SyntheticScene::backgroundPlate(const Camera& camera) const {
  Image8 plate(camera.width, camera.height, 3);
  for (uint32_t y = 0; y < camera.height; ++y) {
    for (uint32_t x = 0; x < camera.width; ++x) {
      const glm::dvec3 c =
          surroundings(camera.center(), camera.rayDirection(x + 0.5, y + 0.5), false).color;
      uint8_t* px = plate.at(x, y);
      for (int k = 0; k < 3; ++k)
        px[k] = static_cast<uint8_t>(std::clamp(c[k] * 255.0 + 0.5, 0.0, 255.0));
    }
  }
  return plate;
}

glm::dvec3 SyntheticScene::shade(const glm::dvec3& p, const glm::dvec3& n, const glm::dvec3& dir,
                                 const Pose& pose, int part, const glm::dvec3& gain) const {
  // Lambertian: the colour of a surface point is the same from every
  // camera up to that camera's gain.
  glm::dvec3 color = albedo(p, pose, part) *
                     (kAmbient + (1 - kAmbient) * std::max(0.0, glm::dot(n, kLight))) * gain;
  if (options_.specular > 0) {
    // Blinn-Phong: where it shines depends on the camera, so views
    // disagree about those pixels (what the vote has to catch).
    const glm::dvec3 half = glm::normalize(kLight - dir);
    color += options_.specular * std::pow(std::max(0.0, glm::dot(n, half)), 40.0) * gain;
  }
  return color;
}

void SyntheticScene::writePixel(RenderedView& view, const Camera& camera, uint64_t frame_id,
                                uint32_t x, uint32_t y, const glm::dvec3& color, bool hit,
                                bool shadowed) const {
  const uint64_t noise_key =
      ((options_.seed * 1000003 + frame_id) * 64 + camera.id) * 0x100000000ull +
      static_cast<uint64_t>(y) * camera.width + x;
  const double light = lightGain(frame_id);
  uint8_t* px = view.color.at(x, y);
  for (int k = 0; k < 3; ++k) {
    const double noise = options_.noise_amplitude * (2 * hashToUnitInterval(noise_key * 3 + k) - 1);
    px[k] = static_cast<uint8_t>(std::clamp(light * color[k] * 255.0 + noise + 0.5, 0.0, 255.0));
  }
  *view.mask.at(x, y) = hit ? 255 : 0;
  if (!view.shadow.empty()) *view.shadow.at(x, y) = shadowed ? 255 : 0;
}

RenderedView SyntheticScene::emptyView(const Camera& camera) const {
  RenderedView view{
      Image8(camera.width, camera.height, 3), Image8(camera.width, camera.height, 1), {}};
  if (options_.studio) view.shadow = Image8(camera.width, camera.height, 1);
  return view;
}

SyntheticScene::PartRect SyntheticScene::projectedRect(const Camera& camera, const Pose& pose,
                                                       int part) {
  Capsule c = pose.parts[part];
  if (part == kTorso) {
    c.a = pose.body_origin + pose.body_to_world * c.a;
    c.b = pose.body_origin + pose.body_to_world * c.b;
  }
  PartRect rect{static_cast<double>(camera.width), static_cast<double>(camera.height), -1, -1};
  for (const glm::dvec3& end : {c.a, c.b}) {
    const auto pixel = camera.project(end);
    if (!pixel)
      return {0, 0, static_cast<double>(camera.width), static_cast<double>(camera.height)};
    const double margin =
        c.radius * std::max(camera.fx, camera.fy) / std::max(pixel->z - c.radius, 1e-3) + 2;
    rect.x0 = std::min(rect.x0, pixel->x - margin);
    rect.y0 = std::min(rect.y0, pixel->y - margin);
    rect.x1 = std::max(rect.x1, pixel->x + margin);
    rect.y1 = std::max(rect.y1, pixel->y + margin);
  }
  return rect;
}

RenderedView SyntheticScene::render(const Camera& camera, uint64_t frame_id) const {
  const Pose pose = poseAt(timeOf(frame_id));
  const glm::dvec3 gain = cameraGain(camera.id);
  const glm::dvec3 origin = camera.center();
  const glm::dvec3 bound_center(pose.body_origin.x, 0.85, pose.body_origin.z);
  const double bound_radius = 1.0;
  RenderedView view = emptyView(camera);
  // Only pixels inside the subject's projected bounding rectangle can hit
  // it: the rest is backdrop without tracing.
  double rx0 = camera.width, ry0 = camera.height, rx1 = -1, ry1 = -1;
  for (int i = 0; i < kPartCount; ++i) {
    const PartRect rect = projectedRect(camera, pose, i);
    rx0 = std::min(rx0, rect.x0);
    ry0 = std::min(ry0, rect.y0);
    rx1 = std::max(rx1, rect.x1);
    ry1 = std::max(ry1, rect.y1);
  }
  for (uint32_t y = 0; y < camera.height; ++y) {
    for (uint32_t x = 0; x < camera.width; ++x) {
      const glm::dvec3 dir = camera.rayDirection(x + 0.5, y + 0.5);
      const Surroundings around = surroundings(origin, dir, options_.late_prop);
      glm::dvec3 color{0.0};
      // Sphere tracing inside the subject's bounding sphere.
      const glm::dvec3 oc = origin - bound_center;
      const double b = glm::dot(oc, dir);
      const double disc = b * b - (glm::dot(oc, oc) - bound_radius * bound_radius);
      const bool in_rect = x + 0.5 >= rx0 && x + 0.5 <= rx1 && y + 0.5 >= ry0 && y + 0.5 <= ry1;
      bool hit = false;
      if (in_rect && disc > 0) {
        double t = std::max(0.0, -b - std::sqrt(disc));
        const double t_end = -b + std::sqrt(disc);
        int part = 0;
        for (int step = 0; step < 128 && t < t_end; ++step) {
          const double d = distance(origin + t * dir, pose, &part);
          if (d < 2e-4) {
            hit = true;
            break;
          }
          t += d;
        }
        hit = hit && t < around.t;  // the prop or the floor may be nearer
        if (hit) {
          const glm::dvec3 p = origin + t * dir;
          const double e = 5e-4;
          const glm::dvec3 n =
              glm::normalize(glm::dvec3(distance(p + glm::dvec3(e, 0, 0), pose, nullptr) -
                                            distance(p - glm::dvec3(e, 0, 0), pose, nullptr),
                                        distance(p + glm::dvec3(0, e, 0), pose, nullptr) -
                                            distance(p - glm::dvec3(0, e, 0), pose, nullptr),
                                        distance(p + glm::dvec3(0, 0, e), pose, nullptr) -
                                            distance(p - glm::dvec3(0, 0, e), pose, nullptr)));
          color = shade(p, n, dir, pose, part, gain);
        }
      }
      bool shadowed = false;
      if (!hit) color = surroundingsColor(around, pose, &shadowed);
      writePixel(view, camera, frame_id, x, y, color, hit, shadowed);
    }
  }
  return view;
}

Mesh SyntheticScene::truthMesh(uint64_t frame_id, double spacing) const {
  const Pose pose = poseAt(timeOf(frame_id));
  glm::dvec3 lo, hi;
  subjectBounds(lo, hi);
  const glm::ivec3 n = glm::ivec3(glm::ceil((hi - lo) / spacing)) + 1;
  const ScalarGrid grid = sampleGrid(
      lo, spacing, n.x, n.y, n.z, [&](const glm::dvec3& p) { return -distance(p, pose, nullptr); });
  return marchingCubes(grid);
}

CameraRenderer::CameraRenderer(const SyntheticScene& scene, const Camera& camera)
    : scene_(scene), camera_(camera) {
  rays_.reserve(static_cast<size_t>(camera.width) * camera.height);
  around_.reserve(rays_.capacity());
  for (uint32_t y = 0; y < camera.height; ++y) {
    for (uint32_t x = 0; x < camera.width; ++x) {
      rays_.push_back(camera.rayDirection(x + 0.5, y + 0.5));
      around_.push_back(
          scene.surroundings(camera.center(), rays_.back(), scene.options().late_prop));
    }
  }
}

RenderedView CameraRenderer::render(uint64_t frame_id) const {
  using Pose = SyntheticScene::Pose;
  const Pose pose = scene_.poseAt(scene_.timeOf(frame_id));
  const glm::dvec3 gain = scene_.cameraGain(camera_.id);
  const glm::dvec3 origin = camera_.center();
  const uint32_t width = camera_.width, height = camera_.height;
  RenderedView view = scene_.emptyView(camera_);
  // The tracer stops where the field is under 2e-4 m: each capsule grown
  // by that much is what it stops on. The torso's field is its capsule's
  // in body space with depth stretched by kTorsoDepthScale, divided by
  // it, so there the ray is cast in that space against a capsule grown
  // by 2e-4 times the scale (t is the same in both spaces).
  constexpr double kStop = 2e-4;
  std::array<Capsule, kPartCount> grown = pose.parts;
  for (int i = 0; i < kPartCount; ++i)
    grown[i].radius += kStop * (i == kTorso ? kTorsoDepthScale : 1.0);
  const glm::dmat3 to_body = glm::transpose(pose.body_to_world);
  const glm::dvec3 stretch(1, 1, kTorsoDepthScale);
  const glm::dvec3 body_origin = stretch * (to_body * (origin - pose.body_origin));
  std::array<SyntheticScene::PartRect, kPartCount> rects;
  for (int i = 0; i < kPartCount; ++i) rects[i] = SyntheticScene::projectedRect(camera_, pose, i);
  for (uint32_t y = 0; y < height; ++y) {
    const double py = y + 0.5;
    // The parts whose rectangles this row crosses.
    int row_parts[kPartCount], row_count = 0;
    for (int i = 0; i < kPartCount; ++i) {
      if (py >= rects[i].y0 && py <= rects[i].y1) row_parts[row_count++] = i;
    }
    for (uint32_t x = 0; x < width; ++x) {
      const size_t index = static_cast<size_t>(y) * width + x;
      const glm::dvec3& dir = rays_[index];
      const SyntheticScene::Surroundings& around = around_[index];
      glm::dvec3 color{0.0};
      const double px = x + 0.5;
      // Only what is nearer than the floor or the prop is seen.
      double entry = around.t;
      int part = -1;
      for (int k = 0; k < row_count; ++k) {
        const int i = row_parts[k];
        if (px < rects[i].x0 || px > rects[i].x1) continue;
        const double t = i == kTorso
                             ? capsuleEntry(body_origin, stretch * (to_body * dir), grown[i])
                             : capsuleEntry(origin, dir, grown[i]);
        if (t >= 0 && t < entry) {
          entry = t;
          part = i;
        }
      }
      const bool hit = part >= 0;
      if (hit) {
        const glm::dvec3 p = origin + entry * dir;
        // The field's gradient there: the hit capsule's, from its axis
        // (for the torso, carried back from the stretched body space).
        glm::dvec3 n;
        const Capsule& c = pose.parts[part];
        const glm::dvec3 q = part == kTorso ? stretch * pose.toBody(p) : p;
        const glm::dvec3 ba = c.b - c.a;
        const double baba = glm::dot(ba, ba);
        const double h = baba > 0 ? std::clamp(glm::dot(q - c.a, ba) / baba, 0.0, 1.0) : 0.0;
        n = q - c.a - ba * h;
        if (part == kTorso) n = pose.body_to_world * (stretch * n);
        n = glm::normalize(n);
        color = scene_.shade(p, n, dir, pose, part, gain);
      }
      bool shadowed = false;
      if (!hit) color = scene_.surroundingsColor(around, pose, &shadowed);
      scene_.writePixel(view, camera_, frame_id, x, y, color, hit, shadowed);
    }
  }
  return view;
}

}  // namespace holofuse::scene
