#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
// Fragment blending of the pod images (paper 000 eq. 1):
//   colour = sum_i w_i * M_i(project_i(p)) / sum_i w_i
// mode normal: w_i = V_i * max(0, n . d_i)^alpha computed here, with V_i the
//   per-fragment test (inside image and mask, not behind the depth map);
// modes holoportation and montage4d: w_i are the per-vertex texture fields
//   (eq. 2, or eqs. 4 and 5 normalised) computed by the compute passes and
//   interpolated over the triangle.
// Where the fields give no weight the normal-weighted blend fills in; a
// fragment no camera contributes to gets the hole colour: never a division
// by zero.

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec4 in_weights[4];
layout(location = 0) out vec4 out_color;
// The depth maps of the compute passes (depth_raster.comp.glsl).
layout(std430, set = 0, binding = HOLOFUSE_BINDING_DEPTHS) readonly buffer DepthMaps { uint depth_bits[]; };

// Normal-weighted blend with the per-fragment occlusion test (mode normal,
// and the fallback of the field modes).
vec4 blendNormal(vec3 n, inout float total) {
  vec3 sum = vec3(0.0);
  total = 0.0;
  for (int i = 0; i < blend.counts.x; ++i) {
    CameraGpu cam = blend.cameras[i];
    // Left out, or its mask is empty: it would sample only background.
    if (cam.flags.x == 0 || cam.flags.y != 0) continue;
    vec4 clip = cam.world_to_clip * vec4(in_position, 1.0);
    if (clip.w <= 1e-6) continue;
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) continue;
    ivec2 pixel = clamp(ivec2(uv * cam.size.xy), ivec2(0), ivec2(cam.size.xy) - 1);
    float stored = uintBitsToFloat(depth_bits[(i * int(cam.size.y) + pixel.y) * int(cam.size.x) + pixel.x]);
    if (clip.w > stored + blend.params.y) continue;  // occluded from camera i
    vec4 texel = textureLod(images, vec3(uv, float(i)), 0.0);
    if (texel.a < 0.5) continue;                     // outside camera i's silhouette
    vec3 to_camera = normalize(cam.center.xyz - in_position);
    // 0 facing away, whatever alpha (pow(0, 0) is undefined in GLSL).
    float c = dot(n, to_camera);
    float w = c > 0.0 ? pow(c, blend.params.x) : 0.0;
    sum += w * texel.rgb;
    total += w;
  }
  return vec4(total > 1e-8 ? sum / total : vec3(0.0), 1.0);
}

// Blend with the interpolated per-vertex texture fields.
vec4 blendFields(inout float total) {
  vec3 sum = vec3(0.0);
  total = 0.0;
  for (int i = 0; i < blend.counts.x; ++i) {
    CameraGpu cam = blend.cameras[i];
    float w = in_weights[i / 4][i % 4];
    if (cam.flags.x == 0 || !(w > 0.0)) continue;
    vec4 clip = cam.world_to_clip * vec4(in_position, 1.0);
    if (clip.w <= 1e-6) continue;
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) continue;
    vec4 texel = textureLod(images, vec3(uv, float(i)), 0.0);
    // Weights are per vertex; near a silhouette a fragment of a visible
    // triangle can still land on the pod's background: never sample that.
    if (texel.a < 0.5) continue;
    sum += w * texel.rgb;
    total += w;
  }
  return vec4(total > 1e-8 ? sum / total : vec3(0.0), 1.0);
}

void main() {
  float len = length(in_normal);
  vec3 n = len > 1e-12 ? in_normal / len : vec3(0.0);
  float total = 0.0;
  vec4 color = vec4(0.0);
  if (blend.counts.y != HOLOFUSE_MODE_NORMAL) color = blendFields(total);
  // Where no field weight reaches the fragment (every camera culled by the
  // dilated discontinuities or the vote), the normal-weighted blend fills
  // in (DESIGN.md section 6, step 10).
  if (!(total > 1e-8)) color = blendNormal(n, total);
  out_color = total > 1e-8 ? color : vec4(blend.hole_color.rgb, 1.0);
}
