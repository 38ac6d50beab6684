// The pod cameras and blend parameters (C++ mirror: BlendUniforms in
// render_client/src/renderer.cpp, with static_asserts on the layout).
struct CameraGpu {
  mat4 world_to_clip;  // w of the result is the camera-space depth
  vec4 center;         // xyz: camera centre in world space
  vec4 size;           // width, height, 1/width, 1/height
  ivec4 flags;         // x: 1 if the camera takes part; y: 1 if its mask is empty (nothing to rasterise)
};

layout(set = 0, binding = HOLOFUSE_BINDING_CAMERAS) uniform Blend {
  CameraGpu cameras[HOLOFUSE_MAX_CAMERAS];
  // x: camera count, y: mode, z: cameras left out for an empty mask, w: 1
  // for half-precision vertices (vertices.glsl)
  ivec4 counts;
  vec4 params;         // x: alpha, y: depth tolerance (metres)
  vec4 hole_color;     // for surface no camera sees
  vec4 user_eye;       // xyz: the user's eye (montage4d, eq. 4)
  vec4 temporal;       // x: lambda of this frame (eq. 5), y: half of the temporal buffer holding the previous field
} blend;

layout(set = 0, binding = HOLOFUSE_BINDING_IMAGES) uniform sampler2DArray images;  // rgb + mask in a, with mips
