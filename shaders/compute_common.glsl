// Push constants of every texture-field compute pass (C++ mirror:
// ComputePush in render_client/include/render_client/texture_field_passes.h).
// They sit after the vertex stage's matrix: ranges of different stages must
// not overlap in one pipeline layout.
layout(push_constant) uniform Push {
  layout(offset = HOLOFUSE_COMPUTE_PUSH_OFFSET) uint vertex_count;
  uint worklist_pass;       // geodesics: the Jacobi pass, whose worklist it reads
  uint width;
  uint height;
  float relative_jump;      // discontinuity: relative depth step
  int dilation;             // discontinuity: eps in pixels
  float depth_tolerance;    // visibility: relative depth tolerance
  float vote_delta;         // voting: Lab distance (scaled by 1/100)
  int vote_levels;          // voting: mip levels searched
  float alpha;              // field exponent
  uint camera_count;
  uint triangle_count;
  uint parity;              // geodesics: which half of the ping-pong buffers is read
  int max_rings;            // geodesics: k
  float geodesic_scale;     // montage: the distance that maps to gamma = 1; geodesics: the reach
  uint temporal_stride;     // floats in one half of the temporal buffer
} push;

#include "vertices.glsl"
// [camera][y][x]: the bits of the camera-space depth (a float), HOLOFUSE_NO_DEPTH where no surface.
layout(std430, set = 0, binding = HOLOFUSE_BINDING_DEPTHS) buffer DepthMaps { uint depth_bits[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_DISCONTINUITIES) buffer Discontinuities { uint discontinuities[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_SIGHTS) buffer Sights { uint sights[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_SIGHT_BITS) buffer SightBits { uint sight_bits[]; };
uint sightWord(uint v, uint set, uint word) { return sight_bits[(v * HOLOFUSE_SIGHT_BIT_SETS + set) * cameraWords() + word]; }
layout(std430, set = 0, binding = HOLOFUSE_BINDING_TRUSTED) buffer Trusted { uint trusted[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_WEIGHTS) buffer Weights { float weights[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_INDICES) readonly buffer Indices { uint indices[]; };
// Per triangle, a bit per camera for each seam rule: [triangle][rule][word].
layout(std430, set = 0, binding = HOLOFUSE_BINDING_SEAMS) buffer Seams { uint seams[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_VISIBLE_COUNTS) buffer VisibleCounts { uint visible_counts[]; };
// adjacency[v] .. adjacency[v + 1] index the triangle list that follows
// the vertex_count + 1 offsets.
layout(std430, set = 0, binding = HOLOFUSE_BINDING_ADJACENCY) readonly buffer Adjacency { uint adjacency[]; };
// Ring count << HOLOFUSE_RING_SHIFT | nearest seam vertex (config.h).
layout(std430, set = 0, binding = HOLOFUSE_BINDING_RINGS) buffer Rings { uint rings[]; };
uint ringOf(uint packed) { return packed >> HOLOFUSE_RING_SHIFT; }
uint sourceOf(uint packed) { return packed & HOLOFUSE_NO_SOURCE; }
uint packRing(uint ring, uint source) { return (ring << HOLOFUSE_RING_SHIFT) | source; }
layout(std430, set = 0, binding = HOLOFUSE_BINDING_DISTANCES) buffer Distances { float distances[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_TEMPORAL) buffer Temporal { float temporal[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_CARRY) readonly buffer Carry { int carry[]; };
// Vertex c's view of one triangle (a, b, c) around it, unfolded into the
// plane once per mesh: a at the origin, b at (ab, 0), c at (cx, cy), cy >= 0.
struct Fan {
  uint a;
  uint b;
  float ab;
  float cx;
  float cy;
  float ac;
  float bc;
  float unused;
};
layout(std430, set = 0, binding = HOLOFUSE_BINDING_FANS) readonly buffer Fans { Fan fans[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_WORKLIST) buffer Worklist { uint worklist[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_WORKLIST_COUNTS) buffer WorklistCounts { uint worklist_counts[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_BEST_VIEWS) buffer BestViews { uvec2 best_views[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_CANDIDATES) buffer Candidates { uvec2 candidates[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_TRIANGLE_VIEWS) buffer TriangleViews { uvec4 triangle_views[]; };

float storedDepth(uint camera, ivec2 pixel) {
  return uintBitsToFloat(depth_bits[(camera * push.height + uint(pixel.y)) * push.width + uint(pixel.x)]);
}


// Pixel coordinates (x right, y down, centres at .5) and depth of p in
// camera i; depth <= 0 means behind the camera.
vec3 projectToCamera(uint i, vec3 p) {
  vec4 clip = cameras[i].world_to_clip * vec4(p, 1.0);
  if (clip.w <= 1e-9) return vec3(-1.0, -1.0, 0.0);
  vec2 ndc = clip.xy / clip.w;
  return vec3((ndc * 0.5 + 0.5) * cameras[i].size.xy, clip.w);
}

// v / |v|, or 0 for a vector too short, infinite or NaN.
vec3 unitOrZero(vec3 v) {
  float l = length(v);
  return (l > 1e-30 && !isinf(l) && !isnan(l)) ? v / l : vec3(0.0);
}

// Inserts camera i with `score` into a list sorted by score, descending,
// of at most k_max entries; equal scores keep camera order (callers go
// through the cameras in order). Returns whether an entry was left out
// (this one or the list's last).
bool insertRanked(inout uint best[HOLOFUSE_MAX_BEST_VIEWS], inout float best_score[HOLOFUSE_MAX_BEST_VIEWS],
                  inout uint kept, uint k_max, uint i, float score) {
  bool full = kept == k_max;
  if (full && !(score > best_score[kept - 1u])) return true;
  uint at = full ? k_max - 1u : kept;
  while (at > 0u && score > best_score[at - 1u]) {
    best[at] = best[at - 1u];
    best_score[at] = best_score[at - 1u];
    --at;
  }
  best[at] = i;
  best_score[at] = score;
  if (!full) ++kept;
  return full;
}

uint bestViewsPerVertex() { return uint(clamp(blend.views.x, 1, HOLOFUSE_MAX_BEST_VIEWS)); }

// The vertex's best views for the blend, from its normalised weights
// [v * camera_count + i]: the blend.views.x largest (ties to the lower
// camera), renormalised to sum 1 where any weight was left out, so that a
// vertex that keeps every weighted camera keeps its weights bit for bit.
// A vertex, not a fragment, pays for the camera count.
void keepBestViews(uint v) {
  uint k_max = bestViewsPerVertex();
  uint best[HOLOFUSE_MAX_BEST_VIEWS];
  float best_weight[HOLOFUSE_MAX_BEST_VIEWS];
  uint kept = 0u;
  bool dropped = false;
  uint base = v * push.camera_count;
  for (uint i = 0u; i < push.camera_count; ++i) {
    float w = weights[base + i];
    if (w > 0.0) dropped = insertRanked(best, best_weight, kept, k_max, i, w) || dropped;
  }
  float kept_total = 0.0;
  for (uint k = 0u; k < kept; ++k) kept_total += best_weight[k];
  for (uint k = 0u; k < k_max; ++k) {
    float w = k < kept ? (dropped ? best_weight[k] / kept_total : best_weight[k]) : 0.0;
    best_views[v * k_max + k] = uvec2(k < kept ? best[k] : HOLOFUSE_NO_VIEW, floatBitsToUint(w));
  }
}

// Offsets of the half a ping-pong pass reads and the half it writes, in the
// [2][camera][vertex] geodesic buffers.
uint readHalf() { return push.parity * push.camera_count * push.vertex_count; }
uint writeHalf() { return (1u - push.parity) * push.camera_count * push.vertex_count; }

// Geodesic worklists: adds (camera, vertex) entry to the list of Jacobi
// pass `pass` once (its mark dedupes), and keeps that pass's indirect
// dispatch size equal to ceil(length / HOLOFUSE_VERTEX_GROUP): an empty
// list dispatches no group at all. Each pass has its own counts, all
// cleared per mesh; the lists and marks rotate through
// HOLOFUSE_WORKLIST_SLOTS slots of storage. The mark keeps
// the highest level asked for: HOLOFUSE_QUEUED_COPY (the entry only
// copies its new value into the other ping-pong half) or
// HOLOFUSE_QUEUED_UPDATE (a neighbour changed: recompute). The list's
// order depends on scheduling, its contents and levels do not, and each
// entry's result depends only on the half it reads: the same input gives
// the same bits.
void enqueueGeodesic(uint pass, uint entry, uint level) {
  uint entries = push.camera_count * push.vertex_count;
  uint slot = pass % HOLOFUSE_WORKLIST_SLOTS;
  uint mark = (HOLOFUSE_WORKLIST_SLOTS + slot) * entries + entry;
  // Most entries are queued already by another neighbour: a plain read
  // skips them without an atomic; the atomic decides the races.
  if (worklist[mark] >= level || atomicMax(worklist[mark], level) != 0u) return;
  uint at = atomicAdd(worklist_counts[4u * pass + 3u], 1u);
  if (at % HOLOFUSE_VERTEX_GROUP == 0u) atomicAdd(worklist_counts[4u * pass], 1u);
  worklist[slot * entries + at] = entry;
}

// Only vertices the camera sees are queued: the distance diffuses from its
// seams towards the triangles it sees (paper 000 section 4.4).
bool queueable(uint base, uint u) { return sights[base + u] == HOLOFUSE_SIGHT_VISIBLE; }

// Whether neighbour u, at surface distance `length` from a vertex now at
// (ring, distance), can take a smaller ring or distance (or an equal
// distance from another seam vertex) from it in the next pass. Every way
// to u through that vertex's triangles is at least distance - length long
// (the triangle inequality in the unfolded plane); the margin covers the
// single-precision unfolding, whose virtual source is off by up to
// sqrt(float epsilon) of its distance where it nearly touches the edge.
// u's values come from the half this pass reads; u's own update this pass
// only lowers them, and then u queues itself.
bool mayLower(uint ring, float distance, float length, uint u_ring, float u_distance) {
  if (ring < uint(push.max_rings) && distance < HOLOFUSE_FAR && ring + 1u < u_ring) return true;
  if (!(distance < HOLOFUSE_FAR)) return false;
  return u_distance >= HOLOFUSE_FAR || distance - length - 1e-3 * (distance + length) < u_distance;
}

// Entry (camera, v) changed to (ring, distance) in this pass. Its next
// Jacobi update could differ from its present value only where a
// neighbour changed; the entries that need a pass next are:
// - v itself, to copy its new value into the other ping-pong half (a
//   neighbour that queues it for an update overrides the copy);
// - the neighbours mayLower says v can improve. Seam vertices (ring 0)
//   never change and are left out.
// Together these are every entry whose full Jacobi update can differ from
// the value it holds in both halves, so the result is the same bits as
// updating every vertex in every pass.
void enqueueChanged(uint pass, uint camera, uint v, uint ring, float distance) {
  uint base = camera * push.vertex_count;
  uint read = readHalf() + base;
  enqueueGeodesic(pass, base + v, HOLOFUSE_QUEUED_COPY);
  for (uint k = adjacency[v]; k < adjacency[v + 1u]; ++k) {
    Fan f = fans[k];
    uint ra = ringOf(rings[read + f.a]), rb = ringOf(rings[read + f.b]);
    if (f.a != v && ra != 0u && queueable(base, f.a) && mayLower(ring, distance, f.ac, ra, distances[read + f.a])) {
      enqueueGeodesic(pass, base + f.a, HOLOFUSE_QUEUED_UPDATE);
    }
    if (f.b != v && rb != 0u && queueable(base, f.b) && mayLower(ring, distance, f.bc, rb, distances[read + f.b])) {
      enqueueGeodesic(pass, base + f.b, HOLOFUSE_QUEUED_UPDATE);
    }
  }
}
