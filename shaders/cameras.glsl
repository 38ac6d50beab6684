// The pod cameras and blend parameters (C++ mirrors: CameraGpu and
// BlendUniforms in render_client/src/renderer_gpu.h, with static_asserts
// on the layout).
struct CameraGpu {
  mat4 world_to_clip;  // w of the result is the camera-space depth
  vec4 center;         // xyz: camera centre in world space
  vec4 size;           // width, height, 1/width, 1/height
  ivec4 flags;         // x: 1 if the camera takes part; y: 1 if its mask is empty (nothing to rasterise)
};

layout(std430, set = 0, binding = HOLOFUSE_BINDING_CAMERAS) readonly buffer Cameras { CameraGpu cameras[]; };

layout(set = 0, binding = HOLOFUSE_BINDING_BLEND) uniform Blend {
  // x: camera count, y: mode, z: cameras left out for an empty mask, w: 1
  // for half-precision vertices (vertices.glsl)
  ivec4 counts;
  vec4 params;         // x: alpha, y: depth tolerance (metres), z: layers, w: the mesh's vertex count
  vec4 hole_color;     // for surface no camera sees
  vec4 user_eye;       // xyz: the user's eye (montage4d eq. 4, fragment's view weight)
  vec4 temporal;       // x: lambda of this frame (eq. 5), y: half of the temporal buffer holding the previous field
  // The per-fragment test of paper 004 (mode fragment, and the field modes
  // when fragment_test.w is 1): x: depth tolerance relative to the
  // camera-space depth, y: absolute depth tolerance in metres (the mesh's
  // mean edge), z: feather width in pixels (0: no feathering), w: 1 if the
  // field modes take the test too.
  vec4 fragment_test;
  // x: beta, the exponent of (d_k . d_v + 1) (paper 004 eq. 4); for the
  // seams, geodesics and visibility overlays: y the overlay pod's camera
  // slot (-1: none), z the half of the distances holding the final ones,
  // w the geodesic scale (gamma's distance 1)
  vec4 view_weight;
  // x: best views kept per vertex (HOLOFUSE_BINDING_BEST_VIEWS), y: words
  // of a per-camera bit set, z: 1 if the per-fragment blends weigh each
  // vertex's candidates, w: entries per triangle of its merged best views
  // (HOLOFUSE_BINDING_TRIANGLE_VIEWS): min(3 x, camera count)
  ivec4 views;
  vec4 relight;         // x: 1 to relight the fragment (blend.frag.glsl, paper 000 eqs. 6 to 8)
  mat4 world_to_view;   // the user camera's rotation into view space (x right, y up, z back)
  vec4 light_probe[9];  // spherical harmonics of the probe, bands 0 to 2, rgb
} blend;

uint cameraWords() { return uint(blend.views.y); }

layout(set = 0, binding = HOLOFUSE_BINDING_IMAGES) uniform sampler2DArray images;  // rgb + mask in a, with mips
layout(set = 0, binding = HOLOFUSE_BINDING_FEATHERS) uniform sampler2DArray feathers;  // r: distance / 255
