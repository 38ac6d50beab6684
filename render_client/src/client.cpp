#include "render_client/client.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include "codec/image_codec.h"
#include "geometry/camera.h"

namespace holofuse::render {

namespace {

// The axis the pods stand around: the normal of the plane through their
// centres (any order: every pair's cross product is parallel to it), with
// the sign most pods' own up direction agrees with; the pods' mean up
// direction when they do not span a plane (one or two pods, a line).
glm::dvec3 ringAxis(const std::map<uint32_t, Camera>& cameras) {
  glm::dvec3 mean(0.0), up_sum(0.0);
  for (const auto& [id, cam] : cameras) {
    mean += cam.center();
    up_sum += -(glm::transpose(cam.rotation) * glm::dvec3(0, 1, 0));  // image up in the world
  }
  mean /= static_cast<double>(cameras.size());
  glm::dvec3 axis(0.0), reference(0.0);
  double scale = 0;
  for (auto a = cameras.begin(); a != cameras.end(); ++a) {
    scale = std::max(scale, glm::length(a->second.center() - mean));
    for (auto b = std::next(a); b != cameras.end(); ++b) {
      glm::dvec3 n = glm::cross(a->second.center() - mean, b->second.center() - mean);
      if (glm::length(reference) == 0 && glm::length(n) > 0) reference = n;
      axis += glm::dot(n, reference) < 0 ? -n : n;
    }
  }
  if (!(glm::length(axis) > 1e-9 * scale * scale)) {
    return glm::length(up_sum) > 1e-9 ? glm::normalize(up_sum) : glm::dvec3(0, 1, 0);
  }
  axis = glm::normalize(axis);
  // Pods may be rotated 180 degrees in their image plane; the majority
  // decides which way is up.
  int agree = 0;
  for (const auto& [id, cam] : cameras) {
    agree += glm::dot(axis, -(glm::transpose(cam.rotation) * glm::dvec3(0, 1, 0))) >= 0 ? 1 : -1;
  }
  return agree >= 0 ? axis : -axis;
}

// v turned by degrees around the unit axis (Rodrigues).
glm::dvec3 turned(const glm::dvec3& v, const glm::dvec3& axis, double degrees) {
  const double a = degrees * std::numbers::pi / 180.0;
  return v * std::cos(a) + glm::cross(axis, v) * std::sin(a) +
         axis * glm::dot(axis, v) * (1.0 - std::cos(a));
}

}  // namespace

// The orbit runs at the pods' mean distance and height with their mean
// field of view. A pod view turned by the jump keeps the pod's intrinsics
// and turns its pose around the ring axis through the subject.
std::optional<Camera> userCamera(const ClientOptions& options,
                                 const std::map<uint32_t, Camera>& cameras, const Bounds& bounds,
                                 size_t frame_index, const OrbitHold& hold) {
  if (cameras.empty()) return std::nullopt;
  const glm::dvec3 target = 0.5 * (glm::dvec3(bounds.min) + glm::dvec3(bounds.max));
  const glm::dvec3 up = ringAxis(cameras);
  const double jump = options.jump_degrees != 0 && frame_index >= options.jump_at_frame
                          ? options.jump_degrees
                          : 0.0;
  auto fovX = [](const Camera& cam) {
    return 2.0 * std::atan(0.5 * cam.width / cam.fx) * 180.0 / std::numbers::pi;
  };
  if (options.run.view.rfind("pod:", 0) == 0) {
    const uint32_t id = static_cast<uint32_t>(std::stoul(options.run.view.substr(4)));
    auto it = cameras.find(id);
    if (it == cameras.end()) return std::nullopt;
    Camera pod = it->second;
    if (jump == 0) return pod;
    // The pod's whole pose turned, its intrinsics kept: the camera-to-world
    // rotation becomes Q R^T, so world-to-camera R Q^T.
    const glm::dmat3 q(turned({1, 0, 0}, up, jump), turned({0, 1, 0}, up, jump),
                       turned({0, 0, 1}, up, jump));
    const glm::dvec3 eye = target + turned(pod.center() - target, up, jump);
    pod.rotation = pod.rotation * glm::transpose(q);
    pod.translation = -(pod.rotation * eye);
    return pod;
  }
  // In-plane basis: the world's z (else x) projected onto the ring plane.
  glm::dvec3 e1 = glm::dvec3(0, 0, 1) - up * up.z;
  if (glm::length(e1) < 0.1) e1 = glm::dvec3(1, 0, 0) - up * up.x;
  e1 = glm::normalize(e1);
  const glm::dvec3 e2 = glm::cross(up, e1);
  double radius = 0, height = 0, fov_x = 0;
  for (const auto& [id, cam] : cameras) {
    const glm::dvec3 offset = cam.center() - target;
    height += glm::dot(offset, up);
    radius += glm::length(offset - up * glm::dot(offset, up));
    fov_x += fovX(cam);
  }
  const double n = static_cast<double>(cameras.size());
  radius /= n;
  height /= n;
  fov_x /= n;
  const double degrees =
      hold.held ? hold.yaw
                : options.orbit_degrees_per_frame * static_cast<double>(frame_index) + jump;
  const double angle = degrees * std::numbers::pi / 180.0;
  const glm::dvec3 around = std::cos(angle) * e1 + std::sin(angle) * e2;
  glm::dvec3 eye = target + up * height + radius * around;
  if (!hold.held)
    return lookAtCamera(kOrbitCameraId, eye, target, up, options.width, options.height, fov_x);
  // Held: pitched about the target, nearer or farther, moved sideways.
  const double pitch = std::clamp(hold.pitch, -85.0, 85.0) * std::numbers::pi / 180.0;
  const glm::dvec3 offset = eye - target;
  const double distance = glm::length(offset) * std::clamp(hold.zoom, 0.05, 20.0);
  const double elevation = std::asin(std::clamp(glm::dot(glm::normalize(offset), up), -1.0, 1.0));
  const double lifted = std::clamp(elevation + pitch, -1.5, 1.5);
  const glm::dvec3 right = glm::normalize(glm::cross(around, up));
  const glm::dvec3 moved_target = target + radius * (hold.pan_right * right + hold.pan_up * up);
  eye = moved_target + distance * (std::cos(lifted) * around + std::sin(lifted) * up);
  return lookAtCamera(kOrbitCameraId, eye, moved_target, up, options.width, options.height, fov_x);
}

uint64_t featherBytes(const protocol::TextureBundle& bundle) {
  uint64_t bytes = 0;
  for (const auto& image : bundle.images) {
    for (const auto& plane : image.planes)
      bytes += plane.kind == protocol::PlaneKind::kFeather ? plane.data.size() : 0;
  }
  return bytes;
}

StatusOr<std::vector<ViewImages>> viewsOfBundle(const protocol::TextureBundle& bundle,
                                                const std::map<uint32_t, Camera>& cameras) {
  std::vector<ViewImages> views;
  for (const auto& image : bundle.images) {
    auto malformed = [&](const std::string& what) {
      return Status(StatusCode::kMalformed, "camera " + std::to_string(image.camera_id) + what);
    };
    auto cam = cameras.find(image.camera_id);
    if (cam == cameras.end()) return malformed(" has no calibration");
    ViewImages view;
    view.camera = cam->second;
    for (const auto& plane : image.planes) {
      auto decoded = decodePlane(plane);
      if (!decoded.isOk()) return malformed(": " + decoded.status().message());
      if (plane.kind == protocol::PlaneKind::kColor) view.color = std::move(*decoded);
      if (plane.kind == protocol::PlaneKind::kMask) view.mask = std::move(*decoded);
      if (plane.kind == protocol::PlaneKind::kFeather) view.feather = std::move(*decoded);
    }
    // A feather map is optional (a 1.1 server sends none), but one that is
    // sent covers the colour's rectangle, as one grey plane (SPEC.md 1.2).
    if (!view.feather.pixels.empty() &&
        (view.feather.width != view.color.width || view.feather.height != view.color.height ||
         view.feather.channels != 1)) {
      return malformed(" feather map is " + std::to_string(view.feather.width) + "x" +
                       std::to_string(view.feather.height) + " with " +
                       std::to_string(view.feather.channels) +
                       " channel(s), not one grey plane of the colour's " +
                       std::to_string(view.color.width) + "x" + std::to_string(view.color.height));
    }
    // A rectangle of the image (the pods send their foreground's): back
    // into a whole frame, background black with mask 0.
    const bool whole = image.offset_x == 0 && image.offset_y == 0 &&
                       view.color.width == view.camera.width &&
                       view.color.height == view.camera.height;
    if (!whole && view.color.width == view.mask.width && view.color.height == view.mask.height &&
        cropFits(image.offset_x, image.offset_y, view.color.width, view.color.height,
                 view.camera.width, view.camera.height)) {
      // (The feather map is the colour's rectangle too, checked above.)
      if (!view.feather.pixels.empty()) {
        view.feather = placeInFrame(view.feather, image.offset_x, image.offset_y, view.camera.width,
                                    view.camera.height);
      }
      view.color = placeInFrame(view.color, image.offset_x, image.offset_y, view.camera.width,
                                view.camera.height);
      view.mask = placeInFrame(view.mask, image.offset_x, image.offset_y, view.camera.width,
                               view.camera.height);
    }
    if (view.color.width != view.camera.width || view.color.height != view.camera.height ||
        view.mask.width != view.camera.width || view.mask.height != view.camera.height ||
        view.color.channels != 3 || view.mask.channels != 1) {
      return malformed(" images are not " + std::to_string(view.camera.width) + "x" +
                       std::to_string(view.camera.height) + " RGB + mask");
    }
    views.push_back(std::move(view));
  }
  return views;
}

StatusOr<DecodedLayers> layersOfBundle(const protocol::BundleLayers& layers,
                                       const std::map<uint32_t, Camera>& cameras,
                                       LayerStreams* streams) {
  auto malformed = [](const std::string& what) {
    return Status(StatusCode::kMalformed, "texture layers: " + what);
  };
  DecodedLayers out;
  out.layout.texels = layers.texels;
  out.layout.squares_per_side = layers.squares_per_side;
  out.layout.square_texels = layers.square_texels;
  out.layout.lattice = glm::u64vec3(layers.lattice[0], layers.lattice[1], layers.lattice[2]);
  out.layout.chart_cells = layers.chart_cells;
  out.layout.texel_metres = layers.texel_metres;
  out.layout.charts_face_surface_around = layers.charts_face_surface_around;
  // The server's atlas grows to 4096 at most (fusion flags): past that a
  // bundle would make the client hold gigabytes of layers.
  if (layers.texels < kMinAtlasTexels || layers.texels > kMaxLayerAtlasTexels)
    return malformed("an atlas of " + std::to_string(layers.texels) + " texels, not " +
                     std::to_string(kMinAtlasTexels) + ".." + std::to_string(kMaxLayerAtlasTexels));
  if (layers.squares_per_side == 0 ||
      uint64_t{layers.squares_per_side} * layers.square_texels > layers.texels ||
      layers.square_count > uint64_t{layers.squares_per_side} * layers.squares_per_side)
    return malformed(std::to_string(layers.square_count) + " squares in a grid of " +
                     std::to_string(layers.squares_per_side) + " a side of " +
                     std::to_string(layers.square_texels) + " texels in " +
                     std::to_string(layers.texels));
  auto slots = decodeAtlasSlots(layers.slots, layers.square_count);
  if (!slots.isOk()) return slots.status();
  out.layout.slots = std::move(*slots);
  for (const uint32_t id : layers.camera_ids) {
    const auto camera = cameras.find(id);
    if (camera == cameras.end())
      return malformed("camera " + std::to_string(id) + " has no calibration");
    out.views.camera_centers.push_back(camera->second.center());
  }
  for (size_t l = 0; l < layers.layers.size(); ++l) {
    std::optional<Image8> colour, camera;
    for (const protocol::Plane& plane : layers.layers[l]) {
      if (plane.kind != protocol::PlaneKind::kColor && plane.kind != protocol::PlaneKind::kCamera)
        continue;
      if (plane.width != layers.texels || plane.height != layers.texels)
        return malformed("layer " + std::to_string(l) + " has a " + std::to_string(plane.width) +
                         "x" + std::to_string(plane.height) + " plane in an atlas of " +
                         std::to_string(layers.texels));
      const auto decode = [&]() -> StatusOr<Image8> {
        if (!isVideoCodec(plane.codec)) return decodePlane(plane);
        if (streams == nullptr || plane.kind != protocol::PlaneKind::kColor)
          return Status(StatusCode::kMalformed, "no stream to decode video in");
        while (streams->decoders.size() <= l)
          streams->decoders.push_back(std::make_unique<LayerVideoDecoder>(kMaxLayerAtlasTexels));
        return streams->decoders[l]->decode(plane);
      };
      auto decoded = decode();
      if (!decoded.isOk())
        return malformed("layer " + std::to_string(l) + ": " + decoded.status().message());
      (plane.kind == protocol::PlaneKind::kColor ? colour : camera) = std::move(*decoded);
    }
    if (!colour || !camera || colour->channels != 3 || camera->channels != 1)
      return malformed("layer " + std::to_string(l) +
                       " needs an RGB colour and a grey camera plane");
    Image8 layer(layers.texels, layers.texels, 4);
    for (size_t i = 0, n = size_t{layers.texels} * layers.texels; i < n; ++i) {
      for (int c = 0; c < 3; ++c) layer.pixels[4 * i + c] = colour->pixels[3 * i + c];
      layer.pixels[4 * i + 3] = camera->pixels[i];
    }
    out.views.layers.push_back(std::move(layer));
  }
  if (Status usable = checkLayeredViews(out.views); !usable.isOk()) return usable;
  return out;
}

}  // namespace holofuse::render
