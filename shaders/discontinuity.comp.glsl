#version 450
#extension GL_GOOGLE_include_directive : require
#include "config.h"
#include "cameras.glsl"
#include "compute_common.glsl"
// Stage 2 (paper 000 section 4.2): whether each vertex lies in each
// camera's depth discontinuities dilated by eps pixels. A surface pixel is
// a discontinuity where a 4-neighbour is empty or farther by more than
// relative_jump times the nearer depth; dilation marks every pixel within
// the square of radius eps around one.
//
// The dilated map is only ever read at the pixel a vertex projects to (by
// the visibility pass), so it is evaluated there and nowhere else: one
// invocation per vertex instead of one per pixel and a pass per dilation
// axis. The result is the same as the whole map sampled at that pixel
// (render::reference::dilatedDiscontinuities); on lavapipe the whole map
// took 0.9-1.0 ms for 4 cameras at 320x240 and this pass 0.4-0.5 ms, and
// no pixel-sized buffer is needed. For eps above 0 the window costs
// 2 (2 eps + 1)(2 eps + 3) loads at most (windowHasDiscontinuity; a vertex
// stops at the first discontinuity it finds).
layout(local_size_x = HOLOFUSE_VERTEX_GROUP) in;

const float kOutside = -1.0;  // beyond the image's border: continuous

float depthAt(uint camera, ivec2 q) {
  if (q.x < 0 || q.y < 0 || q.x >= int(push.width) || q.y >= int(push.height)) return kOutside;
  return storedDepth(camera, q);
}

// Neighbour depth e breaks the surface at depth d: empty, or a relative
// jump; outside the image counts as continuous.
bool breaks(float d, float e) {
  return e != kOutside && (e >= HOLOFUSE_NO_DEPTH * 0.5 || abs(e - d) > push.relative_jump * min(d, e));
}

// Pixel p of the camera's map holds surface at depth d with a break beside it.
bool breaksAround(uint camera, ivec2 p, float d) {
  return breaks(d, depthAt(camera, p + ivec2(-1, 0))) || breaks(d, depthAt(camera, p + ivec2(1, 0))) ||
         breaks(d, depthAt(camera, p + ivec2(0, -1))) || breaks(d, depthAt(camera, p + ivec2(0, 1)));
}

bool hasSurface(float d) { return d != kOutside && d < HOLOFUSE_NO_DEPTH * 0.5; }

// Some pixel of the square of radius eps around `centre` is a
// discontinuity: it has surface and breaks with a 4-neighbour. Every
// break is between two neighbours, so the rows of the square are scanned
// pair by pair along x, and its columns along y (one load a pixel in each
// scan, where testing each pixel's four neighbours would take five).
bool windowHasDiscontinuity(uint camera, ivec2 centre, int eps) {
  for (int scan = 0; scan < 2; ++scan) {
    ivec2 along = scan == 0 ? ivec2(1, 0) : ivec2(0, 1), across = ivec2(1, 1) - along;
    for (int line = -eps; line <= eps; ++line) {
      ivec2 start = centre + across * line - along * (eps + 1);
      float previous = depthAt(camera, start);
      for (int k = 1; k <= 2 * eps + 2; ++k) {
        float current = depthAt(camera, start + along * k);
        // The pair (k - 1, k): each end inside the square (steps 1 to
        // 2 eps + 1 along the line) with surface, breaking with the other.
        if (k - 1 >= 1 && hasSurface(previous) && breaks(previous, current)) return true;
        if (k <= 2 * eps + 1 && hasSurface(current) && breaks(current, previous)) return true;
        previous = current;
      }
    }
  }
  return false;
}

void main() {
  uint v = gl_GlobalInvocationID.x;
  if (v >= push.vertex_count) return;
  vec3 p = vertexPosition(v);
  int eps = max(push.dilation, 0);
  uint bits[HOLOFUSE_MAX_CAMERA_WORDS];
  for (uint word = 0u; word < HOLOFUSE_MAX_CAMERA_WORDS; ++word) bits[word] = 0u;
  for (uint i = 0u; i < push.camera_count; ++i) {
    vec3 q = projectToCamera(i, p);
    vec2 size = cameras[i].size.xy;
    if (!(q.z > 0.0 && q.x >= 0.0 && q.y >= 0.0 && q.x < size.x && q.y < size.y)) continue;
    ivec2 pixel = ivec2(q.xy);
    float depth = storedDepth(i, pixel);
    // Visibility reads the flag only for a vertex that passes its depth
    // test (visibility.comp.glsl): a vertex well behind the depth map is
    // left 0 and costs no neighbourhood. "Well": visibility is another
    // pipeline and may round the projection an ulp the other way. The
    // margin covers the depth; a vertex within a hair of a pixel border
    // may land in the neighbouring pixel there, whose depth may differ by
    // a jump, so it is always tested (across a jump both pixels are
    // discontinuities, and the flag says so).
    vec2 within = fract(q.xy);
    bool on_border = any(lessThan(within, vec2(1e-3))) || any(greaterThan(within, vec2(1.0 - 1e-3)));
    if (!on_border && q.z > depth * (1.0 + push.depth_tolerance) * (1.0 + 1e-4)) continue;
    bool near = false;
    if (eps == 0) {
      // paper 000's 4 px at 2048 wide rounds to 0 below about 615 wide:
      // the vertex's own pixel, whose depth is loaded already.
      near = depth < HOLOFUSE_NO_DEPTH * 0.5 && breaksAround(i, pixel, depth);
    } else {
      near = windowHasDiscontinuity(i, pixel, eps);
    }
    if (near) bits[i / 32u] |= 1u << (i % 32u);
  }
  uint words = cameraWords();
  for (uint word = 0u; word < words; ++word) discontinuities[v * words + word] = bits[word];
}
