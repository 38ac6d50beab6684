#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 4 (paper 000 eq. 3): multi-level majority voting in Lab. Camera
// i's colour at a vertex is trusted when it agrees (Lab distance / 100 <
// delta) with at least floor(X/2) of the other views that see the vertex,
// at some mip level searched from coarse to fine. Also packs each vertex's
// sights and votes into its sight bits (config.h) for the seams and the
// count. delta 0 trusts every view that sees the vertex (no vote).
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

float linearize(float c) { return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4); }
float labF(float t) { return t > 216.0 / 24389.0 ? pow(t, 1.0 / 3.0) : (24389.0 / 27.0 * t + 16.0) / 116.0; }

vec3 labOf(vec3 rgb) {
  vec3 l = vec3(linearize(rgb.r), linearize(rgb.g), linearize(rgb.b));
  float x = dot(vec3(0.4124564, 0.3575761, 0.1804375), l) / 0.95047;
  float y = dot(vec3(0.2126729, 0.7151522, 0.0721750), l);
  float z = dot(vec3(0.0193339, 0.1191920, 0.9503041), l) / 1.08883;
  float fx = labF(x), fy = labF(y), fz = labF(z);
  return vec3(116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)) / 100.0;
}

void main() {
  uint v = gl_GlobalInvocationID.x;
  if (v >= push.vertex_count) return;
  vec3 p = vertexPosition(v);
  uint seen[HOLOFUSE_MAX_CAMERAS];
  vec2 uv[HOLOFUSE_MAX_CAMERAS];
  uint count = 0u;
  // [set][word], HOLOFUSE_MAX_CAMERA_WORDS words a set (config.h's sight bit sets).
  uint bits[HOLOFUSE_SIGHT_BIT_SETS * HOLOFUSE_MAX_CAMERA_WORDS];
  for (uint k = 0u; k < HOLOFUSE_SIGHT_BIT_SETS * HOLOFUSE_MAX_CAMERA_WORDS; ++k) bits[k] = 0u;
  for (uint i = 0u; i < push.camera_count; ++i) {
    trusted[i * push.vertex_count + v] = 0u;
    uint s = sights[i * push.vertex_count + v];
    bool hidden = s == HOLOFUSE_SIGHT_OCCLUDED || s == HOLOFUSE_SIGHT_DISCONTINUITY;
    uint word = i / 32u, bit = 1u << (i % 32u);
    if (hidden) bits[HOLOFUSE_BITS_HIDDEN * HOLOFUSE_MAX_CAMERA_WORDS + word] |= bit;
    if (hidden || s == HOLOFUSE_SIGHT_VISIBLE) bits[HOLOFUSE_BITS_IN_VIEW * HOLOFUSE_MAX_CAMERA_WORDS + word] |= bit;
    if (s != HOLOFUSE_SIGHT_VISIBLE) continue;
    bits[HOLOFUSE_BITS_SEEN * HOLOFUSE_MAX_CAMERA_WORDS + word] |= bit;
    vec3 q = projectToCamera(i, p);
    seen[count] = i;
    uv[count] = q.xy * cameras[i].size.zw;
    ++count;
  }
  uint needed = count / 2u;  // floor(X / 2)
  bool ok[HOLOFUSE_MAX_CAMERAS];
  // delta 0: no vote, every view that sees the vertex is trusted.
  bool vote = push.vote_delta > 0.0;
  for (uint a = 0u; a < count; ++a) ok[a] = !vote;
  // Coarse to fine: each view's Lab colour once per level, then the votes.
  for (int level = vote ? push.vote_levels - 1 : -1; level >= 0; --level) {
    vec3 lab[HOLOFUSE_MAX_CAMERAS];
    for (uint a = 0u; a < count; ++a) lab[a] = labOf(textureLod(images, vec3(uv[a], float(seen[a])), float(level)).rgb);
    for (uint a = 0u; a < count; ++a) {
      if (ok[a]) continue;
      uint agree = 0u;
      for (uint b = 0u; b < count; ++b) {
        if (b != a && length(lab[a] - lab[b]) < push.vote_delta) ++agree;
      }
      ok[a] = agree >= needed;
    }
  }
  for (uint a = 0u; a < count; ++a) {
    trusted[seen[a] * push.vertex_count + v] = ok[a] ? 1u : 0u;
    if (ok[a]) bits[HOLOFUSE_BITS_TRUSTED * HOLOFUSE_MAX_CAMERA_WORDS + seen[a] / 32u] |= 1u << (seen[a] % 32u);
  }
  uint words = cameraWords();
  for (uint set = 0u; set < HOLOFUSE_SIGHT_BIT_SETS; ++set) {
    for (uint word = 0u; word < words; ++word) {
      sight_bits[(v * HOLOFUSE_SIGHT_BIT_SETS + set) * words + word] = bits[set * HOLOFUSE_MAX_CAMERA_WORDS + word];
    }
  }
}
