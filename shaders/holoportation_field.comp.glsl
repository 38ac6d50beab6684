#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stages 8 and 10 of the Holoportation baseline (paper 000 eq. 2): per
// vertex T^i = V^i * max(0, n . d_i)^alpha, d_i towards camera i, then
// normalised over the cameras. All zero where no camera sees the vertex
// (the fragment stage paints the hole colour there).
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint v = gl_GlobalInvocationID.x;
  if (v >= push.vertex_count) return;
  vec3 p = vertexPosition(v);
  vec3 n = vertexNormal(v);
  float len = length(n);
  n = (len > 1e-20 && !isnan(len) && !isinf(len)) ? n / len : vec3(0.0);
  // The fields go straight to the weights and are normalised there: a
  // private array of HOLOFUSE_MAX_CAMERAS floats spills to memory on a CPU
  // device (as in montage_field.comp.glsl).
  uint at = v * push.camera_count;
  float sum = 0.0;
  for (uint i = 0u; i < push.camera_count; ++i) {
    weights[at + i] = 0.0;
    uint index = i * push.vertex_count + v;
    if (sights[index] != HOLOFUSE_SIGHT_VISIBLE || trusted[index] == 0u) continue;
    if (cameras[i].flags.x == 0) continue;
    vec3 d = cameras[i].center.xyz - p;
    float dl = length(d);
    float c = dl > 0.0 ? dot(n, d / dl) : 0.0;
    float w = c > 0.0 ? pow(min(c, 1.0), max(push.alpha, 0.0)) : 0.0;
    w = (isnan(w) || isinf(w)) ? 0.0 : w;
    weights[at + i] = w;
    sum += w;
  }
  for (uint i = 0u; i < push.camera_count; ++i) {
    weights[at + i] = sum > 1e-12 ? weights[at + i] / sum : 0.0;
  }
  keepBestViews(v);
}
