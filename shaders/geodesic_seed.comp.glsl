#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 6, start (paper 000 section 4.4): the sources of camera i's
// distance field are the vertices of its seam triangles (ring 0, distance
// 0); everything else starts unreached, in both ping-pong halves. Gathered
// per vertex from its triangles, so no two invocations write the same
// word. The first Jacobi pass runs densely over the entries the camera
// sees (geodesic_distance.comp.glsl), so nothing is queued here.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint v = gl_GlobalInvocationID.x;
  uint camera = gl_GlobalInvocationID.y;
  if (v >= push.vertex_count || camera >= push.camera_count) return;
  bool source = false;
  for (uint k = adjacency[v]; k < adjacency[v + 1u] && !source; ++k) {
    source = seams[camera * push.triangle_count + adjacency[push.vertex_count + 1u + k]] != 0u;
  }
  uint index = camera * push.vertex_count + v;
  uint half_size = push.camera_count * push.vertex_count;
  rings[index] = rings[half_size + index] = source ? packRing(0u, v) : packRing(HOLOFUSE_NO_RING, HOLOFUSE_NO_SOURCE);
  distances[index] = distances[half_size + index] = source ? 0.0 : HOLOFUSE_FAR;
}
