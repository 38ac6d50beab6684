#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
// Fragment blending of the pod images (paper 000 eq. 1):
//   colour = sum_i w_i * M_i(project_i(p)) / sum_i w_i
// mode normal: w_i = V_i * max(0, n . d_i)^alpha computed here, with V_i the
//   per-fragment test (inside image and mask, not behind the depth map by
//   more than an absolute tolerance);
// mode fragment (Li, Magnor, Seidel 2004, eqs. 1 to 4):
//   w_k = V_k * F_k * max(0, d_k . n)^alpha * (d_k . d_v + 1)^beta,
//   V_k the per-fragment test with a tolerance that follows depth and the
//   mesh's scale, F_k the pod's feather weight, d_v towards the user's eye;
// mode layered (Volino and Hilton 2016, eqs. 3 and 4): per layer, the
//   colour and camera the atlas holds at the fragment, weighed by
//   w_j = max((d_j . n)(d_j . d_v), 0)^HOLOFUSE_LAYER_VIEW_POWER
//   (render::reference::blendLayers);
// modes holoportation and montage4d: w_i are the per-vertex texture fields
//   (eq. 2, or eqs. 4 and 5 normalised) computed by the compute passes and
//   interpolated over the triangle, times V_k * F_k when the field modes
//   take the per-fragment test (docs/design.md section 6).
// Where the weights give nothing the normal-weighted blend fills in; a
// fragment no camera contributes to gets the hole colour: never a division
// by zero.

// The mode, fixed when the pipeline is made (one pipeline per mode): on a
// CPU device (lavapipe) every branch runs with its lanes masked off rather
// than being skipped, so a mode read from the uniforms paid for all five
// modes' blends in every fragment, four times mode normal's own cost.
layout(constant_id = 0) const int kBlendMode = HOLOFUSE_MODE_NORMAL;
// The viewer's overlay (BlendSettings::overlay, config.h's
// HOLOFUSE_OVERLAY_*): camera colours blend each camera's own colour in
// place of its image, so the weights show as colours (paper 000, Figure
// 7's style); seams, geodesics and visibility paint one pod's fields
// (blend.view_weight.yzw) over the picture.
layout(constant_id = 1) const int kOverlay = HOLOFUSE_OVERLAY_NONE;

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) flat in uint in_triangle;
layout(location = 3) in vec3 in_barycentric;
layout(location = 0) out vec4 out_color;
// The depth maps of the compute passes (depth_raster.comp.glsl).
layout(std430, set = 0, binding = HOLOFUSE_BINDING_DEPTHS) readonly buffer DepthMaps { uint depth_bits[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_INDICES) readonly buffer Indices { uint indices[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_CANDIDATES) readonly buffer Candidates { uvec2 candidates[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_TRIANGLE_VIEWS) readonly buffer TriangleViews { uvec4 triangle_views[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_CORNER_UVS) readonly buffer CornerUvs { vec2 corner_uvs[]; };
layout(set = 0, binding = HOLOFUSE_BINDING_LAYERS) uniform sampler2DArray layers;
layout(std430, set = 0, binding = HOLOFUSE_BINDING_LAYER_CAMERAS) readonly buffer LayerCameras { vec4 layer_cameras[]; };
// The field passes' results, read by the overlays only.
layout(std430, set = 0, binding = HOLOFUSE_BINDING_SIGHTS) readonly buffer Sights { uint sights[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_SEAMS) readonly buffer Seams { uint seams[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_DISTANCES) readonly buffer Distances { float distances[]; };

// Where p lands in camera i: texture coordinates in [0, 1] and the
// camera-space depth; false behind the camera or off its image.
bool projectInto(int i, vec3 p, out vec2 uv, out float depth) {
  vec4 clip = cameras[i].world_to_clip * vec4(p, 1.0);
  depth = clip.w;
  uv = vec2(0.0);
  if (clip.w <= 1e-6) return false;
  uv = clip.xy / clip.w * 0.5 + 0.5;
  return all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0)));
}

// Camera i's overlay colour: hues a golden-ratio step apart, saturated.
vec3 cameraColour(int i) {
  float h = fract(float(i) * 0.618034) * 6.0;
  return clamp(vec3(abs(h - 3.0) - 1.0, 2.0 - abs(h - 2.0), 2.0 - abs(h - 4.0)), 0.0, 1.0);
}

// What camera i adds at a fragment: its image's colour there, or its own
// colour under the overlay.
vec3 shade(int i, vec3 texel) { return kOverlay == HOLOFUSE_OVERLAY_CAMERA_COLOURS ? cameraColour(i) : texel; }

// Camera i's depth map at the pixel uv falls in.
float storedDepth(int i, vec2 uv) {
  vec2 size = cameras[i].size.xy;
  ivec2 pixel = clamp(ivec2(uv * size), ivec2(0), ivec2(size) - 1);
  return uintBitsToFloat(depth_bits[(i * int(size.y) + pixel.y) * int(size.x) + pixel.x]);
}

// Tap k (x = k & 1, y = k >> 1) of the bilinear filter at uv in camera
// i's images: between texel centres, clamped at the border, as the CPU
// reference samples them. Filtered here in float: a GPU's own filter of an
// 8-bit image rounds the result to 8 bits (for the feather map, a whole
// pixel of distance: 6% of an 8-pixel ramp).
ivec3 bilinearTap(int i, vec2 uv, int k, out float weight) {
  ivec2 size = ivec2(cameras[i].size.xy);
  vec2 texel = uv * vec2(size) - 0.5;
  ivec2 base = ivec2(floor(texel));
  vec2 f = texel - vec2(base);
  ivec2 offset = ivec2(k & 1, k >> 1);
  weight = (offset.x == 1 ? f.x : 1.0 - f.x) * (offset.y == 1 ? f.y : 1.0 - f.y);
  return ivec3(clamp(base + offset, ivec2(0), size - 1), i);
}

// Camera i's image at uv over its foreground only: each texel weighted by
// its mask too, so that the pod's background beside the silhouette never
// bleeds into the subject's colour. a is the mask's bilinear coverage
// (a >= 0.5 inside the silhouette).
vec4 sampleForeground(int i, vec2 uv) {
  vec4 sum = vec4(0.0);
  for (int k = 0; k < 4; ++k) {
    float w;
    vec4 t = texelFetch(images, bilinearTap(i, uv, k, w), 0);
    sum += w * vec4(t.rgb * t.a, t.a);
  }
  return vec4(sum.a > 1e-6 ? sum.rgb / sum.a : vec3(0.0), sum.a);
}

// Camera i's feather map at uv, in pixels.
float featherAt(int i, vec2 uv) {
  float sum = 0.0;
  for (int k = 0; k < 4; ++k) {
    float w;
    ivec3 tap = bilinearTap(i, uv, k, w);
    sum += w * texelFetch(feathers, tap, 0).r;
  }
  return sum * 255.0;
}

// V_k * F_k of paper 004 at this fragment: 0 on camera k's background or
// behind its depth map by more than the tolerance (relative to the depth,
// plus the mesh's mean edge: a fragment of the surface the map holds lies
// within a pixel's footprint of it); else the feather ramp
// min(1, distance to the silhouette's edge / width), 1 without feathering.
float sightAndFeather(int i, vec2 uv, float depth, float mask) {
  if (mask < 0.5) return 0.0;
  if (depth > storedDepth(i, uv) * (1.0 + blend.fragment_test.x) + blend.fragment_test.y) return 0.0;
  float width = blend.fragment_test.z;
  if (!(width > 0.0)) return 1.0;
  return clamp(featherAt(i, uv) / width, 0.0, 1.0);
}

// Camera i takes part and the fragment lands on its image (uv, depth as
// projectInto); not when it is left out or its mask is empty: it would
// sample only background.
bool imagedBy(int i, out vec2 uv, out float depth) {
  uv = vec2(0.0);
  depth = 0.0;
  if (cameras[i].flags.x == 0 || cameras[i].flags.y != 0) return false;
  return projectInto(i, in_position, uv, depth);
}

// The cameras the per-fragment blends weigh (mode normal, mode fragment,
// the field modes' fallback), each once: the candidates (binding
// CANDIDATES) its triangle's corners keep, when blend.views.z is 1 (more
// cameras than best views; else every camera).
uint picked[3 * HOLOFUSE_MAX_BEST_VIEWS];
uint picked_count = 0u;

void gatherCandidates() {
  uint k_max = uint(clamp(blend.views.x, 1, HOLOFUSE_MAX_BEST_VIEWS));
  for (uint j = 0u; j < 3u; ++j) {
    uint corner = indices[3u * in_triangle + j];
    for (uint k = 0u; k < k_max; ++k) {
      uint i = candidates[corner * k_max + k].x;
      if (i == HOLOFUSE_NO_VIEW) break;
      uint at = 0u;
      while (at < picked_count && picked[at] != i) ++at;
      if (at == picked_count) picked[picked_count++] = i;
    }
  }
}

uint viewCount(bool from_lists) { return from_lists ? picked_count : uint(blend.counts.x); }
int viewAt(bool from_lists, uint u) { return int(from_lists ? picked[u] : u); }

// Normal-weighted blend with the per-fragment occlusion test (mode normal,
// and the fallback of the others).
vec4 blendNormal(vec3 n, bool from_lists, inout float total) {
  vec3 sum = vec3(0.0);
  total = 0.0;
  for (uint u = 0u; u < viewCount(from_lists); ++u) {
    int i = viewAt(from_lists, u);
    CameraGpu cam = cameras[i];
    vec2 uv;
    float depth;
    if (!imagedBy(i, uv, depth)) continue;
    if (depth > storedDepth(i, uv) + blend.params.y) continue;  // occluded from camera i
    vec4 texel = sampleForeground(i, uv);
    if (texel.a < 0.5) continue;                              // outside camera i's silhouette
    vec3 to_camera = normalize(cam.center.xyz - in_position);
    // 0 facing away, whatever alpha (pow(0, 0) is undefined in GLSL).
    float c = dot(n, to_camera);
    float w = c > 0.0 ? pow(c, blend.params.x) : 0.0;
    sum += w * shade(i, texel.rgb);
    total += w;
  }
  return vec4(total > 1e-8 ? sum / total : vec3(0.0), 1.0);
}

// Mode fragment, paper 004 eqs. 1 to 4. The weights are summed in the log
// domain against the largest so far (each rescale is exact), so exponents
// up to the flags' limits neither overflow nor underflow to all zero; the
// view term is (d_k . d_v + 1)^beta over 2^beta, a factor every camera
// shares, so that it stays within [0, 1].
vec4 blendFragment(vec3 n, bool from_lists, inout float total) {
  vec3 sum = vec3(0.0);
  total = 0.0;
  float largest = -3.0e38;
  vec3 to_eye = blend.user_eye.xyz - in_position;
  float eye_distance = length(to_eye);
  vec3 d_v = eye_distance > 1e-20 ? to_eye / eye_distance : vec3(0.0);
  for (uint u = 0u; u < viewCount(from_lists); ++u) {
    int i = viewAt(from_lists, u);
    CameraGpu cam = cameras[i];
    vec2 uv;
    float depth;
    if (!imagedBy(i, uv, depth)) continue;
    vec4 texel = sampleForeground(i, uv);
    float sight = sightAndFeather(i, uv, depth, texel.a);
    vec3 to_camera = cam.center.xyz - in_position;
    float camera_distance = length(to_camera);
    vec3 d_k = camera_distance > 1e-20 ? to_camera / camera_distance : vec3(0.0);
    float obliqueness = min(dot(d_k, n), 1.0);
    float direction = min(0.5 * (dot(d_k, d_v) + 1.0), 1.0);
    if (!(sight > 0.0) || !(obliqueness > 0.0) || (!(direction > 0.0) && blend.view_weight.x > 0.0)) continue;
    float log_w = log(sight) + blend.params.x * log(obliqueness) +
                  (blend.view_weight.x > 0.0 ? blend.view_weight.x * log(direction) : 0.0);
    if (isnan(log_w) || isinf(log_w)) continue;
    if (log_w > largest) {
      float rescale = exp(largest - log_w);  // 0 for the first camera
      sum *= rescale;
      total *= rescale;
      largest = log_w;
    }
    float w = exp(log_w - largest);
    sum += w * shade(i, texel.rgb);
    total += w;
  }
  return vec4(total > 1e-8 ? sum / total : vec3(0.0), 1.0);
}

// Blend with the interpolated per-vertex texture fields: each camera of
// the triangle's merged best views (triangle_views.comp.glsl) with its
// corner weights interpolated over the triangle.
vec4 blendFields(inout float total) {
  vec3 sum = vec3(0.0);
  total = 0.0;
  bool fragment_test = blend.fragment_test.w > 0.5;
  uint slots = uint(blend.views.w);
  for (uint u = 0u; u < slots; ++u) {
    uvec4 entry = triangle_views[in_triangle * slots + u];
    // HOLOFUSE_NO_VIEW ends the list; so does anything that is no camera
    // (a list a measurement stop left unwritten).
    if (entry.x >= uint(blend.counts.x)) break;
    int i = int(entry.x);
    float w = dot(in_barycentric, uintBitsToFloat(entry.yzw));
    CameraGpu cam = cameras[i];
    if (cam.flags.x == 0 || !(w > 0.0)) continue;
    vec2 uv;
    float depth;
    if (!projectInto(i, in_position, uv, depth)) continue;
    vec4 texel = sampleForeground(i, uv);
    w *= fragment_test ? sightAndFeather(i, uv, depth, texel.a) : (texel.a < 0.5 ? 0.0 : 1.0);
    if (!(w > 0.0)) continue;
    sum += w * shade(i, texel.rgb);
    total += w;
  }
  return vec4(total > 1e-8 ? sum / total : vec3(0.0), 1.0);
}

// Mode layered: the layers at the fragment's atlas coordinates. A layer's
// camera is its nearest texel's; its colour bilinear over the taps of that
// camera only, in float as the reference. Eq. 3 weighs each layer, eq. 4
// normalises; where no weight is left the first layer's colour stands
// (total 1), where no layer has a camera none (total 0).
vec4 blendLayers(vec3 n, inout float total) {
  vec2 uv = in_barycentric.x * corner_uvs[3u * in_triangle] +
            in_barycentric.y * corner_uvs[3u * in_triangle + 1u] +
            in_barycentric.z * corner_uvs[3u * in_triangle + 2u];
  int texels = textureSize(layers, 0).x;
  ivec2 nearest = clamp(ivec2(floor(uv * float(texels))), ivec2(0), ivec2(texels - 1));
  vec2 at = uv * float(texels) - 0.5;
  ivec2 base = ivec2(floor(at));
  vec2 f = at - vec2(base);
  vec3 to_eye = blend.user_eye.xyz - in_position;
  vec3 d_v = length(to_eye) > 1e-20 ? normalize(to_eye) : vec3(0.0);
  vec3 sum = vec3(0.0), first = vec3(0.0);
  bool any = false;
  total = 0.0;
  for (int l = 0; l < int(blend.params.z); ++l) {
    uint camera = uint(round(texelFetch(layers, ivec3(nearest, l), 0).a * 255.0));
    if (camera == HOLOFUSE_NO_LAYER_CAMERA) continue;
    vec3 colour = vec3(0.0);
    float weight = 0.0;
    for (int k = 0; k < 4; ++k) {
      ivec2 offset = ivec2(k & 1, k >> 1);
      vec4 t = texelFetch(layers, ivec3(clamp(base + offset, ivec2(0), ivec2(texels - 1)), l), 0);
      if (uint(round(t.a * 255.0)) != camera) continue;
      float w = (offset.x == 1 ? f.x : 1.0 - f.x) * (offset.y == 1 ? f.y : 1.0 - f.y);
      colour += w * t.rgb;
      weight += w;
    }
    if (!(weight > 1e-12)) continue;
    colour = kOverlay == HOLOFUSE_OVERLAY_CAMERA_COLOURS ? cameraColour(int(camera)) : colour / weight;
    if (!any) first = colour;
    any = true;
    vec3 to_camera = layer_cameras[camera].xyz - in_position;
    vec3 d_j = length(to_camera) > 1e-20 ? normalize(to_camera) : vec3(0.0);
    float w = pow(max(dot(d_j, n) * dot(d_j, d_v), 0.0), HOLOFUSE_LAYER_VIEW_POWER);
    sum += w * colour;
    total += w;
  }
  if (total > 1e-8) return vec4(sum / total, 1.0);
  total = any ? 1.0 : 0.0;
  return vec4(first, 1.0);
}

// The overlay colours: fixed values, so that a test can find them.
const vec3 kSeamColour = vec3(1.0, 0.0, 0.0);
const vec3 kUnreachedColour = vec3(0.5, 0.5, 0.5);  // geodesics: a corner the pod does not see
const vec3 kSeenColour = vec3(0.1, 0.85, 0.2);
const vec3 kUnseenColour = vec3(0.35, 0.0, 0.05);

// 0 (at a seam) to 1 (the geodesic radius and beyond): dark blue through
// cyan to yellow, brighter with distance, so that it reads in grey too.
vec3 distanceRamp(float t) {
  t = clamp(t, 0.0, 1.0);
  return clamp(vec3(2.0 * t - 0.6, 1.6 * t, 1.0 - 1.6 * abs(t - 0.35)), 0.0, 1.0);
}

// One pod's fields over the blended colour (kOverlay seams, geodesics or
// visibility): opaque, so that the picture shows the field whatever the
// mode. The pod's slot is blend.view_weight.y; -1 (not in the arrays)
// shows it as seeing nothing.
vec3 overlaid(vec3 colour) {
  int slot = int(blend.view_weight.y);
  uint vertices = uint(blend.params.w);
  uint corner[3] = uint[3](indices[3u * in_triangle], indices[3u * in_triangle + 1u], indices[3u * in_triangle + 2u]);
  if (kOverlay == HOLOFUSE_OVERLAY_SEAMS) {
    if (slot < 0) return colour;
    uint words = uint(blend.views.y), bit = 1u << (uint(slot) % 32u);
    uint at = in_triangle * HOLOFUSE_SEAM_SETS * words + uint(slot) / 32u;
    bool seam = ((seams[at] | seams[at + words] | seams[at + 2u * words]) & bit) != 0u;
    return seam ? kSeamColour : colour;
  }
  if (kOverlay == HOLOFUSE_OVERLAY_GEODESICS) {
    // A corner the pod sees with no distance lies beyond the radius (the
    // ramp's end); one it does not see has none (grey).
    if (slot < 0) return kUnreachedColour;
    float scale = blend.view_weight.w, d = 0.0;
    for (uint j = 0u; j < 3u; ++j) {
      float dj = distances[(uint(blend.view_weight.z) * uint(blend.counts.x) + uint(slot)) * vertices + corner[j]];
      if (!(dj < HOLOFUSE_FAR)) {
        if (sights[uint(slot) * vertices + corner[j]] != HOLOFUSE_SIGHT_VISIBLE) return kUnreachedColour;
        dj = scale;
      }
      d += in_barycentric[j] * dj;
    }
    return distanceRamp(scale > 0.0 ? d / scale : 1.0);
  }
  if (kOverlay == HOLOFUSE_OVERLAY_VISIBILITY) {
    float seen = 0.0;
    for (uint j = 0u; j < 3u && slot >= 0; ++j) {
      if (sights[uint(slot) * vertices + corner[j]] == HOLOFUSE_SIGHT_VISIBLE) seen += in_barycentric[j];
    }
    return mix(kUnseenColour, kSeenColour, clamp(seen, 0.0, 1.0));
  }
  return colour;
}

// Relighting (Du et al. 2019, section 6.2): eq. 6, the normal in view
// space; eq. 7, the probe's light along it (its spherical harmonics,
// bands 0 to 2, Green 2003's constants, clamped); eq. 8 per channel,
// t + |1 - 2 l| (t^(1.5 - l) - t): lighter under a bright light, darker
// under a dark one, unchanged at 50%. CPU reference:
// render::probeLight and render::relightChannel.
vec3 relit(vec3 t, vec3 n) {
  vec3 d = mat3(blend.world_to_view) * n;
  float len = length(d);
  d = len > 1e-12 ? d / len : vec3(0.0);
  float basis[9] = float[9](0.282095, 0.488603 * d.y, 0.488603 * d.z, 0.488603 * d.x,
                            1.092548 * d.x * d.y, 1.092548 * d.y * d.z,
                            0.315392 * (3.0 * d.z * d.z - 1.0), 1.092548 * d.x * d.z,
                            0.546274 * (d.x * d.x - d.y * d.y));
  vec3 l = vec3(0.0);
  for (int k = 0; k < 9; ++k) l += basis[k] * blend.light_probe[k].rgb;
  l = clamp(l, 0.0, 1.0);
  vec3 lifted = vec3(t.r > 0.0 ? pow(t.r, 1.5 - l.r) : 0.0, t.g > 0.0 ? pow(t.g, 1.5 - l.g) : 0.0,
                     t.b > 0.0 ? pow(t.b, 1.5 - l.b) : 0.0);
  return clamp(t + abs(1.0 - 2.0 * l) * (lifted - t), 0.0, 1.0);
}

void main() {
  float len = length(in_normal);
  vec3 n = len > 1e-12 ? in_normal / len : vec3(0.0);
  float total = 0.0;
  vec4 color = vec4(0.0);
  bool field_mode = kBlendMode == HOLOFUSE_MODE_HOLOPORTATION || kBlendMode == HOLOFUSE_MODE_MONTAGE4D;
  if (kBlendMode == HOLOFUSE_MODE_LAYERED) {
    color = blendLayers(n, total);
    out_color = total > 0.0 ? color : vec4(blend.hole_color.rgb, 1.0);
    if (blend.relight.x > 0.5 && total > 0.0) out_color.rgb = relit(out_color.rgb, n);
    return;
  }
  bool candidates = blend.views.z != 0;  // more cameras than K
  if (candidates && !field_mode) gatherCandidates();
  if (kBlendMode == HOLOFUSE_MODE_FRAGMENT) {
    color = blendFragment(n, candidates, total);
  } else if (field_mode) {
    color = blendFields(total);
  }
  // Where no weight reaches the fragment (every camera culled by the
  // dilated discontinuities, the vote or the per-fragment test), the
  // normal-weighted blend fills in (docs/design.md section 6, step 10).
  if (!(total > 1e-8)) {
    if (candidates && field_mode) gatherCandidates();
    color = blendNormal(n, candidates, total);
  }
  out_color = total > 1e-8 ? color : vec4(blend.hole_color.rgb, 1.0);
  if (blend.relight.x > 0.5 && total > 1e-8) out_color.rgb = relit(out_color.rgb, n);
  if (kOverlay >= HOLOFUSE_OVERLAY_SEAMS) out_color.rgb = overlaid(out_color.rgb);
}
