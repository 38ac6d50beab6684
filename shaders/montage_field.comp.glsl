#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stages 8 to 10 of Montage4D (paper 000 eqs. 4 and 5), once per rendered
// view, per vertex:
//   target   T_i = V_i g_i gamma_i max(0, v . v_i)^beta
//            (paper 000 writes this exponent alpha, as the normal weight's;
//            here it is the view weight's exponent, beta, as in paper 004
//            eq. 4 and mode fragment, so that alpha is every mode's normal
//            exponent and beta every mode's view exponent)
//            (v: user eye -> vertex, v_i: camera i -> vertex, gamma_i the
//            geodesic distance to camera i's seams over the normalising
//            distance, g_i camera i's visible count over the largest);
//   temporal F_i = (1 - lambda) F_i(previous, carried to this vertex) + lambda T_i
//            where camera i sees the vertex now, else 0: occlusion is not
//            smoothed, a carried weight would sample the occluder (a vertex
//            new to this mesh starts from T_i);
//   weights  F_i / sum F where sum_i gamma_i >= 1 (gamma_i is 1 where
//            camera i does not see the vertex: its distances reach only
//            what it sees), else the normalised
//            normal-weighted field V_i max(0, n . d_i)^alpha (step 10).
// The current field is stored for the next frame. No NaN or Inf: every
// division and power is guarded. CPU reference: render::reference::
// montageTargetField, temporalUpdate, normalizeFields.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

float guardedPower(float c, float alpha) {
  float w = c > 0.0 ? pow(min(c, 1.0), max(alpha, 0.0)) : 0.0;
  return (isnan(w) || isinf(w)) ? 0.0 : w;
}

void main() {
  uint v = gl_GlobalInvocationID.x;
  if (v >= push.vertex_count) return;
  vec3 p = vertexPosition(v);
  vec3 n = unitOrZero(vertexNormal(v));
  vec3 view = unitOrZero(p - blend.user_eye.xyz);
  uint best = 0u;
  for (uint i = 0u; i < push.camera_count; ++i) best = max(best, visible_counts[i]);
  uint previous_half = uint(blend.temporal.y) * push.temporal_stride;
  uint current_half = (1u - uint(blend.temporal.y)) * push.temporal_stride;
  int from = carry[v];
  float lambda = clamp(blend.temporal.x, 0.0, 1.0);
  // Each camera's field and normal weight go straight to their buffers and
  // are read back for the normalisation: private arrays of
  // HOLOFUSE_MAX_CAMERAS floats spill to memory on a CPU device.
  uint fields_at = current_half + v * push.camera_count, weights_at = v * push.camera_count;
  // Cameras left out of the arrays for an empty mask see no vertex: gamma 1
  // each (blend.counts.z of them).
  float field_sum = 0.0, normal_sum = 0.0, gamma_sum = float(max(blend.counts.z, 0));
  for (uint i = 0u; i < push.camera_count; ++i) {
    uint index = i * push.vertex_count + v;
    float d = distances[push.parity * push.camera_count * push.vertex_count + index];
    float gamma = (d >= HOLOFUSE_FAR || !(push.geodesic_scale > 0.0)) ? 1.0 : clamp(d / push.geodesic_scale, 0.0, 1.0);
    gamma_sum += gamma;
    bool seen = sights[index] == HOLOFUSE_SIGHT_VISIBLE && trusted[index] != 0u && cameras[i].flags.x != 0;
    float target = 0.0, normal = 0.0;
    if (seen) {
      vec3 c = cameras[i].center.xyz;
      float g = best > 0u ? float(visible_counts[i]) / float(best) : 0.0;
      target = g * gamma * guardedPower(dot(view, unitOrZero(p - c)), blend.view_weight.x);
      normal = guardedPower(dot(n, unitOrZero(c - p)), blend.params.x);
    }
    float previous = from >= 0 ? temporal[previous_half + uint(from) * push.camera_count + i] : target;
    if (isnan(previous) || isinf(previous)) previous = target;
    float field = seen ? (1.0 - lambda) * previous + lambda * target : 0.0;
    temporal[fields_at + i] = field;
    weights[weights_at + i] = normal;
    field_sum += field;
    normal_sum += normal;
  }
  bool use_field = gamma_sum >= 1.0 && field_sum > 1e-12;
  for (uint i = 0u; i < push.camera_count; ++i) {
    float w = use_field ? temporal[fields_at + i] / field_sum
                        : (normal_sum > 1e-12 ? weights[weights_at + i] / normal_sum : 0.0);
    weights[weights_at + i] = (isnan(w) || isinf(w)) ? 0.0 : w;
  }
  keepBestViews(v);
}
