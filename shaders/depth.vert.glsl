#version 450
// Depth map of one pod camera: linear depth along the camera's optical axis.
layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;

layout(push_constant) uniform Push {
  mat4 world_to_clip;
} push;

layout(location = 0) out float out_depth;

void main() {
  gl_Position = push.world_to_clip * vec4(in_position, 1.0);
  // Our projection puts the camera-space depth in w.
  out_depth = gl_Position.w;
}
