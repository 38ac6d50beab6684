// Push constants of every texture-field compute pass (C++ mirror:
// ComputePush in render_client/include/render_client/texture_field_passes.h).
// They sit after the vertex stage's matrix: ranges of different stages must
// not overlap in one pipeline layout.
layout(push_constant) uniform Push {
  layout(offset = HOLOFUSE_COMPUTE_PUSH_OFFSET) uint vertex_count;
  uint worklist_slot;       // geodesics: which worklist a pass reads
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

layout(std430, set = 0, binding = HOLOFUSE_BINDING_VERTICES) readonly buffer Vertices { float vertex_data[]; };
// [camera][y][x]: the bits of the camera-space depth (a float), HOLOFUSE_NO_DEPTH where no surface.
layout(std430, set = 0, binding = HOLOFUSE_BINDING_DEPTHS) buffer DepthMaps { uint depth_bits[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_EDGES) buffer Edges { uint edges[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_DILATED) buffer Dilated { uint dilated[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_SIGHTS) buffer Sights { uint sights[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_TRUSTED) buffer Trusted { uint trusted[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_WEIGHTS) buffer Weights { float weights[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_ROWS) buffer Rows { uint rows[]; };  // dilation scratch
layout(std430, set = 0, binding = HOLOFUSE_BINDING_INDICES) readonly buffer Indices { uint indices[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_SEAMS) buffer Seams { uint seams[]; };  // [camera][triangle]
layout(std430, set = 0, binding = HOLOFUSE_BINDING_VISIBLE_COUNTS) buffer VisibleCounts { uint visible_counts[]; };
// adjacency[v] .. adjacency[v + 1] index the triangle list that follows
// the vertex_count + 1 offsets.
layout(std430, set = 0, binding = HOLOFUSE_BINDING_ADJACENCY) readonly buffer Adjacency { uint adjacency[]; };
layout(std430, set = 0, binding = HOLOFUSE_BINDING_RINGS) buffer Rings { uint rings[]; };
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
layout(std430, set = 0, binding = HOLOFUSE_BINDING_NEAREST_SEAM) buffer NearestSeam { uint nearest_seam[]; };

float storedDepth(uint camera, ivec2 pixel) {
  return uintBitsToFloat(depth_bits[(camera * push.height + uint(pixel.y)) * push.width + uint(pixel.x)]);
}

vec3 vertexPosition(uint v) { return vec3(vertex_data[6 * v], vertex_data[6 * v + 1], vertex_data[6 * v + 2]); }
vec3 vertexNormal(uint v) { return vec3(vertex_data[6 * v + 3], vertex_data[6 * v + 4], vertex_data[6 * v + 5]); }

// Pixel coordinates (x right, y down, centres at .5) and depth of p in
// camera i; depth <= 0 means behind the camera.
vec3 projectToCamera(uint i, vec3 p) {
  vec4 clip = blend.cameras[i].world_to_clip * vec4(p, 1.0);
  if (clip.w <= 1e-9) return vec3(-1.0, -1.0, 0.0);
  vec2 ndc = clip.xy / clip.w;
  return vec3((ndc * 0.5 + 0.5) * blend.cameras[i].size.xy, clip.w);
}

// Offsets of the half a ping-pong pass reads and the half it writes, in the
// [2][camera][vertex] geodesic buffers.
uint readHalf() { return push.parity * push.camera_count * push.vertex_count; }
uint writeHalf() { return (1u - push.parity) * push.camera_count * push.vertex_count; }

// Geodesic worklists: adds (camera, vertex) entry to the list of a slot
// once (its mark dedupes), and keeps that slot's indirect dispatch size
// equal to max(1, ceil(length / HOLOFUSE_VERTEX_GROUP)). The list's order depends
// on scheduling, its contents do not, and each entry's result depends only
// on the half it reads: the same input gives the same bits.
void enqueueGeodesic(uint slot, uint entry) {
  uint entries = push.camera_count * push.vertex_count;
  uint mark = (HOLOFUSE_WORKLIST_SLOTS + slot) * entries + entry;
  // Most entries are queued already by another neighbour: a plain read
  // skips them without an atomic; the exchange decides the races.
  if (worklist[mark] != 0u || atomicExchange(worklist[mark], 1u) != 0u) return;
  uint at = atomicAdd(worklist_counts[4u * slot + 3u], 1u);
  // The first group is always there (see the reset): count the others.
  if (at % HOLOFUSE_VERTEX_GROUP == 0u && at != 0u) atomicAdd(worklist_counts[4u * slot], 1u);
  worklist[slot * entries + at] = entry;
}

// An entry whose distance or ring changed, with its neighbours: exactly the
// entries whose next Jacobi update can differ from their present value.
// Seam vertices (ring 0) never change: during the distance passes, whose
// read half nobody writes, they are left out.
// Only vertices the camera sees are queued: the distance diffuses from its
// seams towards the triangles it sees (paper 000 section 4.4).
void enqueueNeighbourhood(uint slot, uint camera, uint v, bool skip_sources) {
  uint base = camera * push.vertex_count;
  uint read = readHalf() + base;
  if ((!skip_sources || rings[read + v] != 0u) && sights[base + v] == HOLOFUSE_SIGHT_VISIBLE) {
    enqueueGeodesic(slot, base + v);
  }
  for (uint k = adjacency[v]; k < adjacency[v + 1u]; ++k) {
    uint a = fans[k].a, b = fans[k].b;
    if ((!skip_sources || rings[read + a] != 0u) && sights[base + a] == HOLOFUSE_SIGHT_VISIBLE) {
      enqueueGeodesic(slot, base + a);
    }
    if ((!skip_sources || rings[read + b] != 0u) && sights[base + b] == HOLOFUSE_SIGHT_VISIBLE) {
      enqueueGeodesic(slot, base + b);
    }
  }
}
