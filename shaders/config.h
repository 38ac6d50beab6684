// Limits and layouts shared by GLSL and C++ (included by both).
#ifndef HOLOFUSE_SHADER_CONFIG_H
#define HOLOFUSE_SHADER_CONFIG_H

// Cameras one render takes. Per-camera data lives in storage buffers sized
// by the cameras present; this bounds only the per-invocation arrays of the
// vote and the global visibility's shared counts.
#define HOLOFUSE_MAX_CAMERAS 128
// Per-camera bit sets are arrays of 32-bit words: ceil(cameras / 32) words.
#define HOLOFUSE_MAX_CAMERA_WORDS (HOLOFUSE_MAX_CAMERAS / 32)
// The blend takes each vertex's best views only (the N best views of
// Volino and Hilton 2013, paper 001; the k nearest cameras of unstructured
// lumigraph rendering, Buehler et al. 2001): its cost per fragment follows
// this, not the camera count.
#define HOLOFUSE_MAX_BEST_VIEWS 16
#define HOLOFUSE_NO_VIEW 0xffffffffu
// Blending modes (render_client/include/render_client/blend_mode.h).
#define HOLOFUSE_MODE_NORMAL 0
#define HOLOFUSE_MODE_HOLOPORTATION 1
#define HOLOFUSE_MODE_MONTAGE4D 2
#define HOLOFUSE_MODE_FRAGMENT 3
#define HOLOFUSE_MODE_LAYERED 4
// The viewer's overlays (render_client/include/render_client/render_settings.h's Overlay).
#define HOLOFUSE_OVERLAY_NONE 0
#define HOLOFUSE_OVERLAY_CAMERA_COLOURS 1
#define HOLOFUSE_OVERLAY_SEAMS 2
#define HOLOFUSE_OVERLAY_GEODESICS 3
#define HOLOFUSE_OVERLAY_VISIBILITY 4
#define HOLOFUSE_OVERLAY_COUNT 5
// Sketchy stippling (stipple.comp.glsl, render::reference::stipple; Du et
// al. 2019, section 6.1): the blur's radius in pixels, how much a dot
// lifts the blurred image the picture is divided by, and the final
// contrast exponent.
#define HOLOFUSE_STIPPLE_RADIUS 2
#define HOLOFUSE_STIPPLE_STRENGTH 1.5
#define HOLOFUSE_STIPPLE_CONTRAST 2.0

// Push constants: the vertex stage's matrix, then the compute passes' block.
#define HOLOFUSE_COMPUTE_PUSH_OFFSET 64

// Workgroup size of the per-vertex and per-triangle passes.
#define HOLOFUSE_VERTEX_GROUP 64

// Depth-map value where no surface was drawn.
#define HOLOFUSE_NO_DEPTH 1.0e9

// Why a vertex is or is not seen by a camera (render::reference::Sight).
#define HOLOFUSE_SIGHT_VISIBLE 0
#define HOLOFUSE_SIGHT_BEHIND 1
#define HOLOFUSE_SIGHT_OUTSIDE_IMAGE 2
#define HOLOFUSE_SIGHT_BACKGROUND 3
#define HOLOFUSE_SIGHT_OCCLUDED 4
#define HOLOFUSE_SIGHT_DISCONTINUITY 5

// Descriptor bindings of the one set shared by the blend and compute passes.
#define HOLOFUSE_BINDING_BLEND 0  // the blend parameters (uniform)
#define HOLOFUSE_BINDING_DEPTHS 1
#define HOLOFUSE_BINDING_IMAGES 2
#define HOLOFUSE_BINDING_VERTICES 3
// per vertex, [vertex][word]: bit i if in camera i's dilated
// discontinuities (computed only where visibility's depth test can pass,
// else 0)
#define HOLOFUSE_BINDING_DISCONTINUITIES 4
#define HOLOFUSE_BINDING_SIGHTS 5
#define HOLOFUSE_BINDING_TRUSTED 6
#define HOLOFUSE_BINDING_WEIGHTS 7
#define HOLOFUSE_BINDING_INDICES 8
#define HOLOFUSE_BINDING_SEAMS 9
#define HOLOFUSE_BINDING_VISIBLE_COUNTS 10
#define HOLOFUSE_BINDING_ADJACENCY 11  // CSR: per vertex the triangles around it
#define HOLOFUSE_BINDING_RINGS \
  12  // [2][camera][vertex] ping-pong: ring count and nearest seam vertex, packed
#define HOLOFUSE_BINDING_DISTANCES 13  // [2][camera][vertex] ping-pong
#define HOLOFUSE_BINDING_TEMPORAL 14   // [2][vertex][camera]: previous and current temporal field
#define HOLOFUSE_BINDING_CARRY 15      // per vertex: its vertex in the previous mesh, -1 for none
#define HOLOFUSE_BINDING_FANS \
  16  // per (vertex, triangle) in ADJACENCY order: the triangle unfolded
#define HOLOFUSE_BINDING_WORKLIST \
  17  // geodesics: [slot][camera * vertex] lists, then [slot][...] marks
#define HOLOFUSE_BINDING_WORKLIST_COUNTS \
  18  // per Jacobi pass: dispatch groups x, y, z, then the list length
// Per vertex, four sets of a bit per camera, [vertex][set][word] (the
// seams and the count read these instead of every camera's sight and
// vote); written by the vote pass.
#define HOLOFUSE_BINDING_SIGHT_BITS 19
#define HOLOFUSE_BITS_HIDDEN 0u   // occluded or in the dilated discontinuities
#define HOLOFUSE_BITS_IN_VIEW 1u  // visible or hidden
#define HOLOFUSE_BITS_SEEN 2u
#define HOLOFUSE_BITS_TRUSTED 3u  // seen and trusted by the vote
#define HOLOFUSE_SIGHT_BIT_SETS 4u
// The pods' feather maps (paper 004: distance to the silhouette's edge in
// pixels, 255 and more as 255), one layer per camera as the images.
#define HOLOFUSE_BINDING_FEATHERS 20
// The cameras (CameraGpu, cameras.glsl), one entry per camera.
#define HOLOFUSE_BINDING_CAMERAS 21
// Per vertex, its best views: [vertex][best_views] pairs (camera,
// weight bits), the camera HOLOFUSE_NO_VIEW where fewer have weight.
#define HOLOFUSE_BINDING_BEST_VIEWS 22
// Past best_views cameras, per vertex the cameras the per-fragment blends
// weigh (mode normal, mode fragment, the field modes' fallback):
// [vertex][best_views] pairs (camera, rank score), as BEST_VIEWS.
#define HOLOFUSE_BINDING_CANDIDATES 23
// Mode layered (Volino and Hilton 2016): per corner, [triangle][3], its
// texture coordinates in the atlas (vec2); the layers, one RGBA layer of
// the image array each (colour, camera index / 255); per camera index,
// its centre (vec4, xyz).
#define HOLOFUSE_BINDING_CORNER_UVS 24
#define HOLOFUSE_BINDING_LAYERS 25
#define HOLOFUSE_BINDING_LAYER_CAMERAS 26
// The field modes: per triangle, its corners' best views merged,
// [triangle][min(3 * best_views, cameras)] of (camera, weight bits at
// corners 0, 1, 2), ended by the camera HOLOFUSE_NO_VIEW where fewer.
#define HOLOFUSE_BINDING_TRIANGLE_VIEWS 27
#define HOLOFUSE_BINDING_COUNT 28
// A layer texel's camera byte where no camera sees the point
// (texture/texture_layers.h kNoLayerCamera).
#define HOLOFUSE_NO_LAYER_CAMERA 255u
// Mode layered's weight, Volino and Hilton 2016 eq. 3 raised to this power:
// ((d_j . n)(d_j . d_v))^4. The paper's own (power 1) mixes a view's three
// layers nearly evenly, which blurs; at 4 the camera nearest the view
// leads (eval's clean scene, 8 frames: SSIM +0.006, many-cameras +0.003,
// against power 1; 8 was no better).
#define HOLOFUSE_LAYER_VIEW_POWER 4.0

// Geodesic worklists and their marks rotate through three slots of storage:
// the one a pass reads (clearing each mark as it goes), the one it appends
// to, and the one the pass before read.
#define HOLOFUSE_WORKLIST_SLOTS 3u
// Levels of a queued geodesic entry (its mark): copy its value across, or recompute it.
#define HOLOFUSE_QUEUED_COPY 1u
#define HOLOFUSE_QUEUED_UPDATE 2u

// Geodesics: rings beyond the bound, distance not reached.
#define HOLOFUSE_NO_RING 0x7fu
#define HOLOFUSE_FAR 3.0e38
#define HOLOFUSE_NO_SOURCE 0x1ffffffu
// A geodesic entry's ring (7 bits, up to HOLOFUSE_NO_RING) and nearest
// seam vertex (25 bits) share one word: one gather per neighbour instead
// of two. Rings stop at k <= 64; meshes for the field passes stay under
// 2^25 - 1 vertices (Renderer::render refuses others).
#define HOLOFUSE_RING_SHIFT 25u
#define HOLOFUSE_MAX_FIELD_VERTICES 0x1ffffffu

// Seam rules (render::reference::SeamRule).
#define HOLOFUSE_SEAM_OCCLUSION 1u
#define HOLOFUSE_SEAM_VOTE 2u
#define HOLOFUSE_SEAM_FIELD_OF_VIEW 4u
// The seams buffer holds per triangle one set of camera bits per rule,
// [triangle][rule][word], in this order.
#define HOLOFUSE_SEAM_SET_OCCLUSION 0u
#define HOLOFUSE_SEAM_SET_VOTE 1u
#define HOLOFUSE_SEAM_SET_FIELD_OF_VIEW 2u
#define HOLOFUSE_SEAM_SETS 3u

#endif
