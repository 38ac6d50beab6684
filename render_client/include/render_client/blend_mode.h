// Blending modes of docs/design.md section 6. Each mode is one value here, one
// branch in shaders/blend.frag.glsl and one CPU reference.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "shaders/config.h"

namespace holofuse::render {

enum class BlendMode : int {
  kNormal = HOLOFUSE_MODE_NORMAL,  // max(0, n . d_i)^alpha with a depth-map occlusion test
  // The Holoportation baseline (paper 000 eq. 2): per-vertex fields with
  // dilated depth discontinuities and multi-level majority voting.
  kHoloportation = HOLOFUSE_MODE_HOLOPORTATION,
  // Montage4D (paper 000 eqs. 4 and 5): view-dependent target fields
  // diffused away from seams by geodesic distance, smoothed in time.
  kMontage4D = HOLOFUSE_MODE_MONTAGE4D,
  // Paper 004 (Li, Magnor, Seidel 2004): per fragment, each pod weighted by
  // its visibility, feather weight, obliqueness and closeness to the view.
  kFragment = HOLOFUSE_MODE_FRAGMENT,
  // Volino and Hilton 2016 (paper 001, eqs. 3 and 4): the server's texture
  // layers in the frame's atlas, each weighed by its camera's direction
  // against the normal and the user's eye; no camera images on the client.
  kLayered = HOLOFUSE_MODE_LAYERED,
};
inline constexpr size_t kBlendModeCount = static_cast<size_t>(BlendMode::kLayered) + 1;

std::optional<BlendMode> blendModeFromName(const std::string& name);
std::string blendModeName(BlendMode mode);
std::vector<std::string> blendModeNames();

// What the viewer draws over the blend (keys F and C, render_client
// --overlay): the texture fields a mode computes, made visible.
enum class Overlay : int {
  kNone = HOLOFUSE_OVERLAY_NONE,
  // Each camera's weight as its own colour in place of its image (paper
  // 000, Figure 7's style).
  kCameraColours = HOLOFUSE_OVERLAY_CAMERA_COLOURS,
  // One pod's seam triangles (occlusion, vote or field of view) in red.
  kSeams = HOLOFUSE_OVERLAY_SEAMS,
  // One pod's geodesic distance from its seams, 0 to the geodesic radius
  // as a colour ramp; grey where no distance was reached.
  kGeodesics = HOLOFUSE_OVERLAY_GEODESICS,
  // Where one pod sees the surface (green) and where not (dark red).
  kVisibility = HOLOFUSE_OVERLAY_VISIBILITY,
};
inline constexpr size_t kOverlayCount = HOLOFUSE_OVERLAY_COUNT;

// A screen-space pass over the final picture (paper 000, section 6; the
// viewer's T key, render_client --stylise).
enum class Stylisation : int {
  kNone = 0,
  kStipple = 1,  // sketchy stippling (section 6.1)
};
std::optional<Stylisation> stylisationFromName(const std::string& name);
std::string stylisationName(Stylisation stylisation);
std::vector<std::string> stylisationNames();

std::optional<Overlay> overlayFromName(const std::string& name);
std::string overlayName(Overlay overlay);
std::vector<std::string> overlayNames();

}  // namespace holofuse::render
