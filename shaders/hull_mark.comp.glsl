#version 450
#extension GL_GOOGLE_include_directive : require
#include "hull_common.glsl"
// The eight corners of every voxel the surface may cross are marked for
// the exact signed distance, and each point once onto the list the
// sampling pass runs over (list_out.x at offset list_out.y): it then
// visits those points only, not the whole grid.
layout(local_size_x = HULL_GROUP) in;

void main() {
  ivec3 a;
  if (!entryOfListIn(a)) return;
  ivec3 b = min(a + 1, push.points.xyz - 1);
  for (int k = 0; k < 8; ++k) {
    ivec3 corner = ivec3((k & 1) != 0 ? b.x : a.x, (k & 2) != 0 ? b.y : a.y, (k & 4) != 0 ? b.z : a.z);
    uint index = gridIndex(corner);
    if (marks[index] == 0u && atomicExchange(marks[index], 1u) == 0u) append(push.list_out.x, push.list_out.y, index);
  }
}
