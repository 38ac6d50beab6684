// The visual hull's grid on the device (hull/vulkan_hull_grid.h): the
// same coarse-to-fine carve as hull::fillHullGrid, in float. Cells and
// voxels are packed as x | y << 10 | z << 20 (grids under 1024 points a
// side; larger ones stay on the CPU).
#define HULL_GROUP 64
#define HULL_INSIDE 0u
#define HULL_OUTSIDE 1u
#define HULL_BOUNDARY 2u

struct HullCamera {
  vec4 rows[3];     // world to camera: rotation rows, translation in w
  vec4 intrinsics;  // fx, fy, cx, cy
  vec4 image;       // skew, width, height, 1 where the lens distorts
  vec4 lens;        // k1, k2, p1, p2
  vec4 lens_k3;     // k3 in x
  uvec4 offsets;    // x: the first pixel of its distance map, y: of its foreground sums
};

layout(std430, set = 0, binding = 0) readonly buffer Cameras { HullCamera cameras[]; };
layout(std430, set = 0, binding = 1) readonly buffer Distances { float distances[]; };
layout(std430, set = 0, binding = 2) readonly buffer Sums { uint sums[]; };
layout(std430, set = 0, binding = 3) buffer Lists { uint lists[]; };
// Per list k: [4k] groups to dispatch over it, [4k + 1] and [4k + 2] one,
// [4k + 3] its length; then the points sampled.
layout(std430, set = 0, binding = 4) buffer Counts { uint counts[]; };
layout(std430, set = 0, binding = 5) buffer Values { float values[]; };
layout(std430, set = 0, binding = 6) buffer Marks { uint marks[]; };
// Marching cubes (hull_march.comp.glsl): per cube configuration, its
// corner count then its triangles' cube edges (geometry's case table);
// the triangles' corners (x: the grid edge's key point * 3 + axis, yzw:
// the vertex, bits of floats); and per cube that has any, (its grid
// index, its first corner, its corner count).
layout(std430, set = 0, binding = 7) readonly buffer CaseTable { uint case_table[]; };
layout(std430, set = 0, binding = 8) writeonly buffer Corners { uvec4 corners[]; };
layout(std430, set = 0, binding = 9) writeonly buffer Cubes { uvec4 cubes[]; };

layout(push_constant) uniform Push {
  vec4 origin;      // xyz: the grid's point (0, 0, 0); w: the spacing
  ivec4 points;     // xyz: points per axis; w: cameras
  uvec4 list_in;    // x: list index read, y: its offset in lists, z: cell size in voxels
  uvec4 list_out;   // x, y: the list children go to; z, w: the settled list
  uvec4 march;      // x: the corners' list, y: its capacity; z: the cubes' list; w: the case table's stride
} push;

bool onBorder(ivec3 a) { return any(equal(a, ivec3(0))) || any(equal(a, push.points.xyz - 1)); }

uint pack(ivec3 a) { return uint(a.x) | (uint(a.y) << 10) | (uint(a.z) << 20); }
ivec3 unpack(uint p) { return ivec3(p & 1023u, (p >> 10) & 1023u, (p >> 20) & 1023u); }
vec3 gridPoint(ivec3 a) { return push.origin.xyz + push.origin.w * vec3(a); }
uint gridIndex(ivec3 a) { return (uint(a.z) * uint(push.points.y) + uint(a.y)) * uint(push.points.x) + uint(a.x); }

// This invocation's entry of the list read (list_in.x at offset
// list_in.y), unpacked; false past its end.
bool entryOfListIn(out ivec3 a) {
  uint item = gl_GlobalInvocationID.x;
  a = ivec3(0);
  if (item >= counts[4u * push.list_in.x + 3u]) return false;
  a = unpack(lists[push.list_in.y + item]);
  return true;
}

// Appends value to list `list` at `offset`, keeping its dispatch size.
void append(uint list, uint offset, uint value) {
  uint at = atomicAdd(counts[4u * list + 3u], 1u);
  if (at % HULL_GROUP == 0u) atomicAdd(counts[4u * list], 1u);
  lists[offset + at] = value;
}

// World point to camera i's coordinates.
vec3 toCamera(uint i, vec3 p) {
  HullCamera c = cameras[i];
  return vec3(dot(c.rows[0].xyz, p) + c.rows[0].w, dot(c.rows[1].xyz, p) + c.rows[1].w,
              dot(c.rows[2].xyz, p) + c.rows[2].w);
}

// Pixel of a camera-space point in front of camera i (Camera::project).
vec2 toPixel(uint i, vec3 c) {
  HullCamera cam = cameras[i];
  float x = c.x / c.z, y = c.y / c.z;
  if (cam.image.w > 0.5) {
    float k1 = cam.lens.x, k2 = cam.lens.y, p1 = cam.lens.z, p2 = cam.lens.w, k3 = cam.lens_k3.x;
    float r2 = x * x + y * y;
    float radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    float xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    float yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
    x = xd;
    y = yd;
  }
  return vec2(cam.intrinsics.x * x + cam.image.x * y + cam.intrinsics.z, cam.intrinsics.y * y + cam.intrinsics.w);
}
