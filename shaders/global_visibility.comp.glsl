#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 7 (paper 000 eq. 4): how many vertices each camera sees and
// trusts. Integer atomics give the same total in any order, so the result
// is deterministic; g^i = count_i / max_j count_j is formed where it is
// used. The counters are cleared before this pass.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

// Each workgroup counts in shared memory, then adds to the global counters
// once per camera: a few global atomics per group instead of one per
// vertex on the same few words (on a CPU device those serialise).
shared uint group_counts[HOLOFUSE_MAX_CAMERAS];

void main() {
  uint v = gl_GlobalInvocationID.x;
  uint local = gl_LocalInvocationID.x;
  for (uint i = local; i < push.camera_count; i += HOLOFUSE_VERTEX_GROUP) group_counts[i] = 0u;
  barrier();
  if (v < push.vertex_count) {
    uint words = cameraWords();
    for (uint word = 0u; word < words; ++word) {
      uint seen_and_trusted = sightWord(v, HOLOFUSE_BITS_TRUSTED, word);
      while (seen_and_trusted != 0u) {
        atomicAdd(group_counts[32u * word + findLSB(seen_and_trusted)], 1u);
        seen_and_trusted &= seen_and_trusted - 1u;
      }
    }
  }
  barrier();
  for (uint i = local; i < push.camera_count; i += HOLOFUSE_VERTEX_GROUP) {
    if (group_counts[i] != 0u) atomicAdd(visible_counts[i], group_counts[i]);
  }
}
