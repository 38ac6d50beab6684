#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 6: one Jacobi pass (of K = 20) of the triangle-ring count and the
// surface distance from camera i's seams; vertices more than k rings or
// push.geodesic_scale (the geodesic radius: gamma is 1 from there on) away
// stay unreached. For each triangle (a, b, c) around vertex c, unfolded
// into the plane (a at the origin, b on the x axis, c above it), the
// virtual source s lies below the axis at distances d_a and d_b from a and
// b. When the straight line s -> c crosses edge ab the distance is |c - s|
// (a surface distance through the triangle), else the way round through a
// or b. The virtual source stands for a real one only when a and b measure
// from the same seam vertex: otherwise only the ways round are offered
// (render::reference::approximateGeodesic says why). The smallest distance
// wins, ties to the smaller source index. Reads half push.parity, writes
// the other: deterministic.
//
// After the first pass, only the entries of this pass's worklist run
// (enqueueChanged says which): any other entry would recompute the value
// it already has, in both halves. The result is the same bits as updating
// every vertex K times, at a fraction of the work.
// CPU reference: render::reference::unfoldedDistance.
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

float unfolded(Fan f, float da, float db) {
  float best = min(da + f.ac, db + f.bc);
  if (da >= HOLOFUSE_FAR || db >= HOLOFUSE_FAR || !(f.ab > 0.0) || !(f.cy > 0.0)) return best;
  float sx = (da * da - db * db + f.ab * f.ab) / (2.0 * f.ab);
  float s2 = da * da - sx * sx;
  if (!(s2 >= 0.0)) return best;
  float sy = -sqrt(s2);
  float t = -sy / (f.cy - sy);
  float x = sx + t * (f.cx - sx);
  if (x >= 0.0 && x <= f.ab) best = min(best, length(vec2(f.cx - sx, f.cy - sy)));
  return best;
}

// A distance d from seam vertex `source` within reach replaces the best so
// far when shorter, or as long and from a smaller source.
void offer(float d, uint source, float reach, inout float candidate, inout uint candidate_source) {
  if (d <= reach && (d < candidate || (d == candidate && source < candidate_source))) {
    candidate = d;
    candidate_source = source;
  }
}

void main() {
  uint pass = push.worklist_pass;
  uint slot = pass % HOLOFUSE_WORKLIST_SLOTS;
  uint entries = push.camera_count * push.vertex_count;
  uint i = gl_GlobalInvocationID.x;
  uint entry = gl_GlobalInvocationID.y * push.vertex_count + i, level = HOLOFUSE_QUEUED_UPDATE;
  if (pass == 0u) {
    // The first pass runs over every entry the camera sees (vertices
    // along x, cameras along y): the seeds would otherwise queue their
    // neighbours, and on lavapipe those scattered marks took 1.3-1.5 ms
    // of the seed pass's 2.0-2.2. An entry with no seam vertex around
    // keeps its values, as it would off the list.
    if (i >= push.vertex_count || sights[entry] != HOLOFUSE_SIGHT_VISIBLE) return;
  } else {
    if (i >= worklist_counts[4u * pass + 3u]) return;
    entry = worklist[slot * entries + i];
    uint mark = (HOLOFUSE_WORKLIST_SLOTS + slot) * entries + entry;
    level = worklist[mark];
    worklist[mark] = 0u;  // clean for its next use
  }
  uint camera = entry / push.vertex_count;
  uint v = entry - camera * push.vertex_count;
  uint base = camera * push.vertex_count;
  uint in_offset = readHalf() + base, out_offset = writeHalf() + base;
  if (level == HOLOFUSE_QUEUED_COPY) {  // changed last pass, no neighbour since: the halves only need to agree
    rings[out_offset + v] = rings[in_offset + v];
    distances[out_offset + v] = distances[in_offset + v];
    return;
  }
  // The triangle ring count advances in the same pass: a distance can only
  // become finite one ring per pass too, so gating by the ring reached so
  // far gives the same result as counting the rings to the end first.
  uint old_packed = rings[in_offset + v];
  uint old_ring = ringOf(old_packed);
  if (old_ring == 0u) return;  // a seam vertex is its own nearest seam vertex, at 0, in both halves
  float old_distance = distances[in_offset + v];
  uint old_source = sourceOf(old_packed);
  uint ring = old_ring;
  float candidate = old_distance;
  uint candidate_source = old_source;
  float reach = push.geodesic_scale;
  if (pass == 0u) {
    // The first pass reads only seeds (ring 0, distance 0, themselves as
    // source) and unreached entries (no source). Through a fan, a seed
    // offers its edge to v and an unreached vertex offers nothing that
    // wins (two unreached corners share "no source", and unfolding from
    // HOLOFUSE_FAR returns at once with HOLOFUSE_FAR or more). So the general update below reduces to the
    // shortest edge to a seed neighbour, ties to the smaller seed, read
    // from the rings alone: the same bits, and on lavapipe about a third
    // of the geodesics' time went into this pass.
    for (uint k = adjacency[v]; k < adjacency[v + 1u]; ++k) {
      uint a = fans[k].a, b = fans[k].b;
      uint pa = rings[in_offset + a], pb = rings[in_offset + b];
      if (ringOf(pa) == 0u) {
        if (a != v && 0u < uint(push.max_rings)) ring = min(ring, 1u);
        offer(fans[k].ac, sourceOf(pa), reach, candidate, candidate_source);
      }
      if (ringOf(pb) == 0u) {
        if (b != v && 0u < uint(push.max_rings)) ring = min(ring, 1u);
        offer(fans[k].bc, sourceOf(pb), reach, candidate, candidate_source);
      }
    }
  }
  for (uint k = adjacency[v]; pass != 0u && k < adjacency[v + 1u]; ++k) {
    Fan f = fans[k];
    uint pa = rings[in_offset + f.a], pb = rings[in_offset + f.b];
    uint ra = ringOf(pa), rb = ringOf(pb);
    float da = distances[in_offset + f.a], db = distances[in_offset + f.b];
    // Rings spread only through reached vertices: past the radius nothing
    // changes, so nothing there is put on a worklist.
    if (f.a != v && ra < uint(push.max_rings) && da < HOLOFUSE_FAR) ring = min(ring, ra + 1u);
    if (f.b != v && rb < uint(push.max_rings) && db < HOLOFUSE_FAR) ring = min(ring, rb + 1u);
    uint sa = sourceOf(pa), sb = sourceOf(pb);
    float d = sa == sb ? unfolded(f, da, db) : da + f.ac;
    offer(d, sa, reach, candidate, candidate_source);
    offer(sa == sb ? d : db + f.bc, sb, reach, candidate, candidate_source);
  }
  bool reached = ring <= uint(push.max_rings);
  float best = reached ? candidate : old_distance;
  uint source = reached ? candidate_source : old_source;
  uint packed = packRing(ring, source);
  rings[out_offset + v] = packed;
  distances[out_offset + v] = best;
  if (packed != old_packed || best != old_distance) {
    enqueueChanged(pass + 1u, camera, v, ring, best);
  }
}
