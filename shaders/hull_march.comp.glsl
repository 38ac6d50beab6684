#version 450
#extension GL_GOOGLE_include_directive : require
#include "hull_common.glsl"
// Marching cubes over the cubes the surface may cross (the carve's voxel
// list: every other cube lies in a settled cell, all inside or all
// outside). Each cube's triangles go out as corners, each the grid edge it
// sits on and the zero crossing placed on it as geometry's marchingCubes
// places it; the host numbers the vertices in grid order, as a scan of
// the whole grid would (hull::VulkanHullGrid::surface).
layout(local_size_x = HULL_GROUP) in;

void main() {
  ivec3 a;
  if (!entryOfListIn(a)) return;
  float corner_values[8];
  uint config = 0u;
  for (int c = 0; c < 8; ++c) {
    corner_values[c] = values[gridIndex(a + ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1))];
    if (corner_values[c] > 0.0) config |= 1u << c;
  }
  uint stride = push.march.w;
  uint count = case_table[config * stride];
  if (count == 0u) return;
  uint base = atomicAdd(counts[4u * push.march.x + 3u], count);
  if (base + count > push.march.y) return;  // past the capacity: the host sees the count and redoes it
  uint cube = atomicAdd(counts[4u * push.march.z + 3u], 1u);
  cubes[cube] = uvec4(gridIndex(a), base, count, 0u);
  float s = push.origin.w;
  for (uint k = 0u; k < count; ++k) {
    uint edge = case_table[config * stride + 1u + k];
    // Edge id = axis * 4 + j: the j-th corner whose bit for the axis is 0.
    uint axis = edge / 4u, j = edge % 4u, seen = 0u;
    int from = 0;
    for (int c = 0; c < 8; ++c) {
      if ((c & (1 << axis)) != 0) continue;
      if (seen++ == j) {
        from = c;
        break;
      }
    }
    int to = from | (1 << axis);
    ivec3 p0 = a + ivec3(from & 1, (from >> 1) & 1, (from >> 2) & 1);
    float v0 = corner_values[from], v1 = corner_values[to];
    // Kept off the end points, so no triangle collapses to zero area.
    float t = clamp(v0 / (v0 - v1), 1e-3, 1.0 - 1e-3);
    vec3 position = gridPoint(p0);
    position[axis] += t * s;
    corners[base + k] = uvec4(gridIndex(p0) * 3u + axis, floatBitsToUint(position));
  }
}
