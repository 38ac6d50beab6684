#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 6: one Jacobi pass (of K = 20) of the triangle-ring count and the
// surface distance from camera i's seams; vertices more than k rings away
// stay unreached. For each triangle (a, b, c) around vertex c the
// triangle is unfolded into the plane: a at the origin, b on the x axis,
// c above it, and the virtual source s below it at distances d_a and d_b
// from a and b. When the straight line s -> c crosses edge ab the distance
// is |c - s| (a surface distance through the triangle), else the way round
// through a or b. Reads half push.parity, writes the other: deterministic.
// CPU reference: render::reference::unfoldedDistance.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

float unfolded(float ab, float ac, float bc, float da, float db) {
  float best = min(da + ac, db + bc);
  if (da >= HOLOFUSE_FAR || db >= HOLOFUSE_FAR || !(ab > 0.0)) return best;
  float cx = (ac * ac - bc * bc + ab * ab) / (2.0 * ab);
  float cy = sqrt(max(ac * ac - cx * cx, 0.0));
  float sx = (da * da - db * db + ab * ab) / (2.0 * ab);
  float s2 = da * da - sx * sx;
  if (!(s2 >= 0.0) || !(cy > 0.0)) return best;
  float sy = -sqrt(s2);
  float t = -sy / (cy - sy);
  float x = sx + t * (cx - sx);
  if (x >= 0.0 && x <= ab) best = min(best, length(vec2(cx - sx, cy - sy)));
  return best;
}

void main() {
  uint v = gl_GlobalInvocationID.x;
  uint camera = gl_GlobalInvocationID.y;
  if (v >= push.vertex_count || camera >= push.camera_count) return;
  uint base = camera * push.vertex_count;
  uint in_offset = readHalf(), out_offset = writeHalf();
  // The triangle ring count advances in the same pass: a distance can only
  // become finite one ring per pass too, so gating by the ring reached so
  // far gives the same result as counting the rings to the end first.
  uint ring = rings[in_offset + base + v];
  for (uint k = adjacency[v]; k < adjacency[v + 1u]; ++k) {
    uint t = adjacency[push.vertex_count + 1u + k];
    for (uint j = 0u; j < 3u; ++j) {
      uint w = indices[3u * t + j];
      uint r = rings[in_offset + base + w];
      if (w != v && r < uint(push.max_rings)) ring = min(ring, r + 1u);
    }
  }
  rings[out_offset + base + v] = ring;
  float best = distances[in_offset + base + v];
  if (ring <= uint(push.max_rings)) {
    vec3 pc = vertexPosition(v);
    for (uint k = adjacency[v]; k < adjacency[v + 1u]; ++k) {
      uint t = adjacency[push.vertex_count + 1u + k];
      uint i0 = indices[3u * t], i1 = indices[3u * t + 1u], i2 = indices[3u * t + 2u];
      // a and b: the triangle's other two vertices, in winding order after c.
      uint a = i0 == v ? i1 : (i1 == v ? i2 : i0);
      uint b = i0 == v ? i2 : (i1 == v ? i0 : i1);
      vec3 pa = vertexPosition(a), pb = vertexPosition(b);
      float d = unfolded(length(pa - pb), length(pa - pc), length(pb - pc), distances[in_offset + base + a],
                         distances[in_offset + base + b]);
      best = min(best, d);
    }
  }
  distances[out_offset + base + v] = best;
}
