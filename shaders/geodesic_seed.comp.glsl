#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 6, start (paper 000 section 4.4): the sources of camera i's
// distance field are the vertices of its seam triangles (ring 0, distance
// 0); everything else starts unreached, in both ping-pong halves. Gathered
// per vertex from its triangles' rule bits, every camera in one
// invocation, so no two invocations write the same word. The first Jacobi
// pass runs densely over the entries the camera sees
// (geodesic_distance.comp.glsl), so nothing is queued here.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

void main() {
  uint v = gl_GlobalInvocationID.x;
  if (v >= push.vertex_count) return;
  // Every camera at once: the cameras for which some triangle around v is
  // a seam, by any rule.
  uint words = cameraWords();
  uint half_size = push.camera_count * push.vertex_count;
  for (uint word = 0u; word < words; ++word) {
    uint sources = 0u;
    for (uint k = adjacency[v]; k < adjacency[v + 1u]; ++k) {
      uint at = adjacency[push.vertex_count + 1u + k] * HOLOFUSE_SEAM_SETS * words + word;
      sources |= seams[at] | seams[at + words] | seams[at + 2u * words];
    }
    for (uint camera = word * 32u; camera < min(push.camera_count, word * 32u + 32u); ++camera) {
      bool source = ((sources >> (camera % 32u)) & 1u) != 0u;
      uint index = camera * push.vertex_count + v;
      rings[index] = rings[half_size + index] = source ? packRing(0u, v) : packRing(HOLOFUSE_NO_RING, HOLOFUSE_NO_SOURCE);
      distances[index] = distances[half_size + index] = source ? 0.0 : HOLOFUSE_FAR;
    }
  }
}
