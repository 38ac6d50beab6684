#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "vertices.glsl"
// The user's view of the fused mesh; world position and normal go on to
// the blend, interpolated over the triangle, with the triangle's index and
// the fragment's barycentric coordinates, with which the blend
// interpolates its corners' best-view weights (paper 000 eq. 1). The draw
// is not indexed: corner c is vertex indices[c] of triangle c / 3, so
// every corner knows its triangle. The vertices come from the storage
// buffer the compute passes read (full or half precision).

layout(push_constant) uniform Push {
  mat4 world_to_clip;
} push;

layout(std430, set = 0, binding = HOLOFUSE_BINDING_INDICES) readonly buffer Indices { uint indices[]; };

layout(location = 0) out vec3 out_position;
layout(location = 1) out vec3 out_normal;
layout(location = 2) flat out uint out_triangle;
layout(location = 3) out vec3 out_barycentric;
// The depth pre-pass and the blend draw with this stage in two pipelines:
// the blend's equal-depth test needs the same depth bits from both.
invariant gl_Position;

void main() {
  uint corner = uint(gl_VertexIndex);
  uint v = indices[corner];
  vec3 in_position = vertexPosition(v);
  gl_Position = push.world_to_clip * vec4(in_position, 1.0);
  out_position = in_position;
  out_normal = vertexNormal(v);
  out_triangle = corner / 3u;
  uint k = corner % 3u;
  out_barycentric = vec3(k == 0u ? 1.0 : 0.0, k == 1u ? 1.0 : 0.0, k == 2u ? 1.0 : 0.0);
}
