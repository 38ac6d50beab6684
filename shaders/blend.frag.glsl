#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
// View-independent normal-weighted blending of the pod images (the
// `normal` mode of DESIGN.md section 6) with a per-camera occlusion test
// against that camera's depth map: camera i contributes
//   w_i = V_i * max(0, n . d_i)^alpha
// where d_i points from the surface to camera i and V_i is 1 when the point
// projects inside camera i's image and foreground mask and is not behind
// its depth map.

struct CameraGpu {
  mat4 world_to_clip;  // w of the result is the camera-space depth
  vec4 center;         // xyz: camera centre in world space
  vec4 size;           // width, height, 1/width, 1/height
  ivec4 flags;         // x: 1 if the camera takes part
};

layout(set = 0, binding = 0) uniform Blend {
  CameraGpu cameras[HOLOFUSE_MAX_CAMERAS];
  ivec4 counts;        // x: camera count, y: mode
  vec4 params;         // x: alpha, y: depth tolerance (metres)
  vec4 hole_color;     // for surface no camera sees
} blend;

layout(set = 0, binding = 1) uniform sampler2DArray images;  // rgb + mask in a
layout(set = 0, binding = 2) uniform sampler2DArray depths;  // linear depth

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 0) out vec4 out_color;

void main() {
  float len = length(in_normal);
  vec3 n = len > 1e-12 ? in_normal / len : vec3(0.0);
  vec3 sum = vec3(0.0);
  float total = 0.0;
  for (int i = 0; i < blend.counts.x; ++i) {
    CameraGpu cam = blend.cameras[i];
    if (cam.flags.x == 0) continue;
    vec4 clip = cam.world_to_clip * vec4(in_position, 1.0);
    if (clip.w <= 1e-6) continue;
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) continue;
    float stored = texture(depths, vec3(uv, float(i))).r;
    if (clip.w > stored + blend.params.y) continue;  // occluded from camera i
    vec4 texel = texture(images, vec3(uv, float(i)));
    if (texel.a < 0.5) continue;                     // outside camera i's silhouette
    vec3 to_camera = normalize(cam.center.xyz - in_position);
    float w = pow(max(dot(n, to_camera), 0.0), blend.params.x);
    sum += w * texel.rgb;
    total += w;
  }
  // A total of zero (nobody sees this point) gets the defined hole colour,
  // never a division by zero.
  out_color = total > 1e-8 ? vec4(sum / total, 1.0) : vec4(blend.hole_color.rgb, 1.0);
}
