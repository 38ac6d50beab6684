#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "vertices.glsl"
// The user's view of the fused mesh; world position, normal and the
// per-vertex texture-field weights (16 cameras as 4 vec4) go on to the
// blend, interpolated over the triangle (paper 000 eq. 1). The vertices
// come from the storage buffer the compute passes read (full or half
// precision), indexed by the draw's vertex index.

layout(push_constant) uniform Push {
  mat4 world_to_clip;
} push;

layout(std430, set = 0, binding = HOLOFUSE_BINDING_WEIGHTS) readonly buffer Weights { float weights[]; };

layout(location = 0) out vec3 out_position;
layout(location = 1) out vec3 out_normal;
layout(location = 2) out vec4 out_weights[4];

void main() {
  vec3 in_position = vertexPosition(uint(gl_VertexIndex));
  vec3 in_normal = vertexNormal(uint(gl_VertexIndex));
  gl_Position = push.world_to_clip * vec4(in_position, 1.0);
  out_position = in_position;
  out_normal = in_normal;
  for (int k = 0; k < 4; ++k) out_weights[k] = vec4(0.0);
  if (blend.counts.y == HOLOFUSE_MODE_HOLOPORTATION || blend.counts.y == HOLOFUSE_MODE_MONTAGE4D) {
    uint base = uint(gl_VertexIndex) * HOLOFUSE_MAX_CAMERAS;
    for (int k = 0; k < 4; ++k) {
      out_weights[k] = vec4(weights[base + 4 * k], weights[base + 4 * k + 1], weights[base + 4 * k + 2],
                            weights[base + 4 * k + 3]);
    }
  }
}
