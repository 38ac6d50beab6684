#version 450
#extension GL_GOOGLE_include_directive : require
#include "hull_common.glsl"
// The exact signed distance at the points of the list the marking pass
// wrote (list_out.x at offset list_out.y), or at every point when
// push.list_in.w is 1 (the dense grid): the smallest of the cameras'
// silhouette distances, bilinear between pixel centres and turned from
// pixels into metres at the point's depth; -spacing where a camera does
// not see the point (hull::fillHullGrid). With push.list_in.w bit 1 the
// grid's outer layer is closed as it is written (at most half a voxel
// inside: hull::surfaceOfGrid); no settled point there is inside.
layout(local_size_x = HULL_GROUP) in;

float sampleDistance(uint i, vec2 q) {
  HullCamera cam = cameras[i];
  int w = int(cam.image.y), h = int(cam.image.z);
  float x = clamp(q.x - 0.5, 0.0, float(w - 1)), y = clamp(q.y - 0.5, 0.0, float(h - 1));
  int x0 = int(x), y0 = int(y);
  int x1 = min(x0 + 1, w - 1), y1 = min(y0 + 1, h - 1);
  float fx = x - float(x0), fy = y - float(y0);
  uint base = cam.offsets.x;
  float top = distances[base + uint(y0 * w + x0)] * (1.0 - fx) + distances[base + uint(y0 * w + x1)] * fx;
  float bottom = distances[base + uint(y1 * w + x0)] * (1.0 - fx) + distances[base + uint(y1 * w + x1)] * fx;
  return top * (1.0 - fy) + bottom * fy;
}

void main() {
  uint index = gl_GlobalInvocationID.x;
  ivec3 n = push.points.xyz;
  if ((push.list_in.w & 1u) != 0u) {
    if (index >= uint(n.x * n.y * n.z)) return;
  } else {
    if (index >= counts[4u * push.list_out.x + 3u]) return;
    index = lists[push.list_out.y + index];
  }
  ivec3 a = ivec3(int(index % uint(n.x)), int((index / uint(n.x)) % uint(n.y)), int(index / uint(n.x * n.y)));
  vec3 p = gridPoint(a);
  float s = push.origin.w;
  float value = 3.0e38;
  for (uint i = 0u; i < uint(push.points.w); ++i) {
    HullCamera cam = cameras[i];
    vec3 c = toCamera(i, p);
    vec2 q = c.z > 1e-9 ? toPixel(i, c) : vec2(-1.0);
    // Written so that NaN counts as outside.
    if (!(c.z > 1e-9) || !(q.x >= 0.0 && q.y >= 0.0 && q.x < cam.image.y && q.y < cam.image.z)) {
      value = -s;
      break;
    }
    value = min(value, sampleDistance(i, q) * c.z / cam.intrinsics.x);
  }
  if ((push.list_in.w & 2u) != 0u && onBorder(a)) value = min(value, -0.5 * s);
  values[index] = value;
}
