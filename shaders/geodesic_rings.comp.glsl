#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 6, reach: one Jacobi pass of the triangle-ring count from the
// sources. A vertex is one ring further than the nearest vertex of any of
// its triangles; after k passes this equals the breadth-first count, and
// vertices more than k rings away stay unreached (the paper's k = 15
// triangles). Reads half push.parity, writes the other half.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint v = gl_GlobalInvocationID.x;
  uint camera = gl_GlobalInvocationID.y;
  if (v >= push.vertex_count || camera >= push.camera_count) return;
  uint base = camera * push.vertex_count;
  uint in_offset = readHalf(), out_offset = writeHalf();
  uint best = rings[in_offset + base + v];
  for (uint k = adjacency[v]; k < adjacency[v + 1u]; ++k) {
    uint t = adjacency[push.vertex_count + 1u + k];
    for (uint j = 0u; j < 3u; ++j) {
      uint w = indices[3u * t + j];
      uint r = rings[in_offset + base + w];
      if (w != v && r < uint(push.max_rings)) best = min(best, r + 1u);
    }
  }
  rings[out_offset + base + v] = best;
}
