#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// The field modes' blend weighs, per fragment, each camera that one of
// its triangle's corners keeps among its best views, with the corners'
// weights interpolated (paper 000 eq. 1 over the per-vertex fields). This
// pass merges the three corners' lists once per triangle, after the field
// pass: each camera once, with its weight at each corner (0 where the
// corner does not keep it). The fragment then reads one list and takes a
// dot product per camera. Merging per fragment, with the search for a
// camera already met, cost lavapipe 3-4 ms of a 23 ms view: its private
// arrays, indexed at run time, spill to memory. A triangle has room for
// as many cameras as there are, at most its corners' 3 K: with room for
// 3 K whatever the rig, the lists of 4 cameras took 8 MB instead of 1.3,
// and the blend's reads missed the cache (6-14 ms a view more, not less).
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint t = gl_GlobalInvocationID.x;
  if (t >= push.triangle_count) return;
  uint k_max = bestViewsPerVertex();
  uint slots = uint(blend.views.w);
  uint base = t * slots;
  uint merged = 0u;
  for (uint j = 0u; j < 3u; ++j) {
    uint corner = indices[3u * t + j];
    for (uint k = 0u; k < k_max; ++k) {
      uvec2 entry = best_views[corner * k_max + k];
      if (entry.x == HOLOFUSE_NO_VIEW) break;
      // The list in hand is this invocation's own: search it in place.
      uint at = 0u;
      while (at < merged && triangle_views[base + at].x != entry.x) ++at;
      if (at == merged) {
        triangle_views[base + at] = uvec4(entry.x, 0u, 0u, 0u);  // 0u: the bits of 0.0
        ++merged;
      }
      triangle_views[base + at][j + 1u] = entry.y;
    }
  }
  if (merged < slots) triangle_views[base + merged].x = HOLOFUSE_NO_VIEW;
}
