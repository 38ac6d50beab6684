#version 450
#extension GL_GOOGLE_include_directive : require
#include "hull_common.glsl"
// The settled cells' points get one voxel inside (+spacing) or outside
// (-spacing), as hull::fillHullGrid's placeholders; cells that share a
// point never disagree on it. One invocation per cell and plane (y of the
// dispatch): a cell of 16 voxels a side is 17 planes of 289 points, and
// lanes that wait on one long loop cost a CPU device as much as the work.
layout(local_size_x = HULL_GROUP) in;

void main() {
  uint item = gl_GlobalInvocationID.x;
  if (item >= counts[4u * push.list_out.z + 3u]) return;
  ivec3 a = unpack(lists[push.list_out.w + 2u * item]);
  uint word = lists[push.list_out.w + 2u * item + 1u];
  ivec3 b = min(a + int(word & 0x7fffffffu), push.points.xyz - 1);
  float value = (word & 0x80000000u) != 0u ? push.origin.w : -push.origin.w;
  int z = a.z + int(gl_GlobalInvocationID.y);
  if (z > b.z) return;
  for (int y = a.y; y <= b.y; ++y)
    for (int x = a.x; x <= b.x; ++x) values[gridIndex(ivec3(x, y, z))] = value;
}
