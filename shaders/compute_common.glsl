// Push constants of every texture-field compute pass (C++ mirror:
// ComputePush in render_client/include/render_client/texture_field_passes.h).
// They sit after the vertex stage's matrix: ranges of different stages must
// not overlap in one pipeline layout.
layout(push_constant) uniform Push {
  layout(offset = HOLOFUSE_COMPUTE_PUSH_OFFSET) uint vertex_count;
  uint reserved;
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
  float geodesic_scale;     // the distance that maps to gamma = 1
  uint temporal_stride;     // floats in one half of the temporal buffer
} push;

layout(std430, set = 0, binding = HOLOFUSE_BINDING_VERTICES) readonly buffer Vertices { float vertex_data[]; };
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
