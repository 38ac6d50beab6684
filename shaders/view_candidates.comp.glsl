#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Modes normal and fragment weigh each pod per fragment, as the field
// modes' fallback does; with more cameras than best views, each vertex
// first picks the cameras its fragments will weigh, so that a fragment
// tests blend.views.x cameras per corner, not every camera. A camera that sees the vertex (in front, inside its image
// and mask, not behind its depth map by more than the normal blend's
// tolerance) ranks above one that does not; among them, by the weight the
// mode gives: max(0, n . d_k) for normal (its order is that of the power
// alpha), and for fragment paper 004's max(0, d_k . n)^alpha (d_k . d_v +
// 1)^beta (Li, Magnor, Seidel 2004, eq. 4) without its per-fragment V_k F_k,
// mapped into [0, 1] by exp(log w / (1 + alpha + beta)), which keeps the
// order. The normal ranking (every mode but fragment) does not depend on
// the view: it runs once per mesh and settings; mode fragment's per
// rendered view (d_v follows the eye). CPU reference: reference::blendView's candidates.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint v = gl_GlobalInvocationID.x;
  if (v >= push.vertex_count) return;
  vec3 p = vertexPosition(v);
  vec3 n = unitOrZero(vertexNormal(v));
  vec3 d_v = unitOrZero(blend.user_eye.xyz - p);
  bool fragment = blend.counts.y == HOLOFUSE_MODE_FRAGMENT;
  float alpha = max(blend.params.x, 0.0), beta = max(blend.view_weight.x, 0.0);
  uint k_max = bestViewsPerVertex();
  uint best[HOLOFUSE_MAX_BEST_VIEWS];
  float best_score[HOLOFUSE_MAX_BEST_VIEWS];
  uint kept = 0u;
  for (uint i = 0u; i < push.camera_count; ++i) {
    if (cameras[i].flags.x == 0 || cameras[i].flags.y != 0) continue;  // weighs nothing anywhere
    vec3 d_k = unitOrZero(cameras[i].center.xyz - p);
    float obliqueness = clamp(dot(d_k, n), 0.0, 1.0);
    float score = obliqueness;
    if (fragment && obliqueness > 0.0) {
      float direction = clamp(0.5 * (dot(d_k, d_v) + 1.0), 0.0, 1.0);
      float log_w = alpha * log(obliqueness) + (beta > 0.0 ? beta * log(max(direction, 1e-30)) : 0.0);
      score = exp(log_w / (1.0 + alpha + beta));
      if (isnan(score) || isinf(score)) score = 0.0;
    }
    vec3 q = projectToCamera(i, p);
    vec2 size = cameras[i].size.xy;
    bool seen = false;
    if (q.z > 0.0 && q.x >= 0.0 && q.y >= 0.0 && q.x < size.x && q.y < size.y) {
      ivec2 pixel = ivec2(q.xy);
      seen = texelFetch(images, ivec3(pixel, int(i)), 0).a > 0.0 &&
             q.z <= storedDepth(i, pixel) + blend.params.y;
    }
    insertRanked(best, best_score, kept, k_max, i, seen ? score + 2.0 : score);
  }
  for (uint k = 0u; k < k_max; ++k) {
    candidates[v * k_max + k] = uvec2(k < kept ? best[k] : HOLOFUSE_NO_VIEW,
                                      floatBitsToUint(k < kept ? best_score[k] : 0.0));
  }
}
