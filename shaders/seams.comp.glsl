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
  uint corners[3] = uint[3](indices[3u * t], indices[3u * t + 1u], indices[3u * t + 2u]);
  uint words = cameraWords();
  for (uint word = 0u; word < words; ++word) {
    uint any_hidden = 0u, all_hidden = ~0u, any_in_view = 0u, all_in_view = ~0u;
    uint any_trusted = 0u, untrusted = 0u;
    for (uint k = 0u; k < 3u; ++k) {
      uint hidden = sightWord(corners[k], HOLOFUSE_BITS_HIDDEN, word);
      uint in_view = sightWord(corners[k], HOLOFUSE_BITS_IN_VIEW, word);
      uint seen = sightWord(corners[k], HOLOFUSE_BITS_SEEN, word);
      uint trusted = sightWord(corners[k], HOLOFUSE_BITS_TRUSTED, word);
      any_hidden |= hidden;
      all_hidden &= hidden;
      any_in_view |= in_view;
      all_in_view &= in_view;
      any_trusted |= trusted;
      untrusted |= seen & ~trusted;
    }
    uint at = t * HOLOFUSE_SEAM_SETS * words + word;
    seams[at + HOLOFUSE_SEAM_SET_OCCLUSION * words] = any_hidden & ~all_hidden;
    seams[at + HOLOFUSE_SEAM_SET_VOTE * words] = any_trusted & untrusted;
    seams[at + HOLOFUSE_SEAM_SET_FIELD_OF_VIEW * words] = any_in_view & ~all_in_view;
  }
}
