#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 5 (paper 000 section 4.3): seam triangles of each camera by the
// three rules, one invocation per triangle:
//   occlusion: some but not all vertices behind the depth map or in its
//     dilated discontinuities;
//   vote: the vertices the camera sees disagree in the majority vote;
//   field of view: some but not all vertices outside the image or on the
//     pod's background.
// The rules are bit operations on each corner's sight bits (a bit per
// camera, written by the vote pass), all cameras at once: three loads a
// triangle instead of two per corner and camera, and one store of every
// camera's rules. On lavapipe the seams and the count went from 0.5-0.6 ms
// to 0.25-0.41 ms for 4 cameras.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint t = gl_GlobalInvocationID.x;
  if (t >= push.triangle_count) return;
  uvec2 a = sight_bits[indices[3u * t]], b = sight_bits[indices[3u * t + 1u]], c = sight_bits[indices[3u * t + 2u]];
  // Per camera bit: some but not all corners hidden / in view; some corner
  // seen and trusted while another seen corner is not.
  uvec2 any_bits = a | b | c, all_bits = a & b & c;
  uint some_not_all = any_bits.x & ~all_bits.x;
  uint occlusion = some_not_all & 0xffffu, field_of_view = some_not_all >> 16;
  uint untrusted = ((a.y & ~(a.y >> 16)) | (b.y & ~(b.y >> 16)) | (c.y & ~(c.y >> 16))) & 0xffffu;
  uint vote = (any_bits.y >> 16) & untrusted;
  seams[t] = uvec2(occlusion | (vote << 16), field_of_view);
}
