#version 450
#extension GL_GOOGLE_include_directive : require
#include "hull_common.glsl"
// One level of the coarse-to-fine carve (hull::fillHullGrid): each cell of
// the list read is inside every silhouette, outside one, or on the
// boundary; settled cells go to the settled list, boundary ones are split
// into their eight children (voxels at the last level). The projected
// corners' box is grown by far more than float rounding, so a cell is
// settled only where the exact points inside would all agree: a cell the
// CPU settles may stay boundary here, never the other way round, and the
// grid's exact points are the same or more.
layout(local_size_x = HULL_GROUP) in;

uint classify(ivec3 a, ivec3 b) {
  vec3 p0 = gridPoint(a), p1 = gridPoint(b);
  bool inside_all = true;
  for (uint i = 0u; i < uint(push.points.w); ++i) {
    HullCamera cam = cameras[i];
    // Lens distortion bends straight edges: such cameras settle nothing.
    if (cam.image.w > 0.5) return HULL_BOUNDARY;
    vec2 lo = vec2(3.0e38), hi = vec2(-3.0e38);
    for (int k = 0; k < 8; ++k) {
      vec3 corner = vec3((k & 1) != 0 ? p1.x : p0.x, (k & 2) != 0 ? p1.y : p0.y, (k & 4) != 0 ? p1.z : p0.z);
      vec3 c = toCamera(i, corner);
      if (!(c.z > 1e-9)) return HULL_BOUNDARY;  // crosses the camera plane
      vec2 q = toPixel(i, c);
      if (isnan(q.x) || isnan(q.y) || isinf(q.x) || isinf(q.y)) return HULL_BOUNDARY;
      lo = min(lo, q);
      hi = max(hi, q);
    }
    float w = cam.image.y, h = cam.image.z;
    float margin = 1e-2 + 1e-5 * max(max(abs(lo.x), abs(lo.y)), max(abs(hi.x), abs(hi.y)));
    lo -= margin;
    hi += margin;
    if (hi.x < 0.0 || hi.y < 0.0 || lo.x >= w || lo.y >= h) return HULL_OUTSIDE;
    bool off_image = lo.x < 0.0 || lo.y < 0.0 || hi.x >= w || hi.y >= h;
    int x0 = int(clamp(lo.x - 0.5, 0.0, w - 1.0)), y0 = int(clamp(lo.y - 0.5, 0.0, h - 1.0));
    int x1 = min(int(clamp(hi.x - 0.5, 0.0, w - 1.0)) + 1, int(w) - 1);
    int y1 = min(int(clamp(hi.y - 0.5, 0.0, h - 1.0)) + 1, int(h) - 1);
    uint stride = uint(w) + 1u, base = cam.offsets.y;
    uint foreground = sums[base + uint(y1 + 1) * stride + uint(x1 + 1)] - sums[base + uint(y0) * stride + uint(x1 + 1)] -
                      sums[base + uint(y1 + 1) * stride + uint(x0)] + sums[base + uint(y0) * stride + uint(x0)];
    if (foreground == 0u) return HULL_OUTSIDE;
    if (off_image || foreground < uint((x1 - x0 + 1) * (y1 - y0 + 1))) inside_all = false;
  }
  return inside_all ? HULL_INSIDE : HULL_BOUNDARY;
}

void main() {
  ivec3 a;
  if (!entryOfListIn(a)) return;
  ivec3 n = push.points.xyz;
  int size = int(push.list_in.z);
  ivec3 b = min(a + size, n - 1);
  uint c = classify(a, b);
  // The grid's outer layer is forced outside afterwards: an inside cell on
  // it is refined, or its points would keep a placeholder there.
  bool on_border = onBorder(a) || onBorder(b);
  if (c == HULL_INSIDE && on_border) c = HULL_BOUNDARY;
  if (c != HULL_BOUNDARY) {
    uint at = atomicAdd(counts[4u * push.list_out.z + 3u], 1u);
    if (at % HULL_GROUP == 0u) atomicAdd(counts[4u * push.list_out.z], 1u);
    lists[push.list_out.w + 2u * at] = pack(a);
    lists[push.list_out.w + 2u * at + 1u] = uint(size) | (c == HULL_INSIDE ? 0x80000000u : 0u);
    return;
  }
  int half_size = size / 2;
  for (int k = 0; k < 8; ++k) {
    ivec3 child = a + half_size * ivec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
    if (all(lessThan(child, n - 1))) append(push.list_out.x, push.list_out.y, pack(child));
  }
}
