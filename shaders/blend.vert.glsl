#version 450
// The user's view of the fused mesh; world position and normal go on to the
// blend.
layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;

layout(push_constant) uniform Push {
  mat4 world_to_clip;
} push;

layout(location = 0) out vec3 out_position;
layout(location = 1) out vec3 out_normal;

void main() {
  gl_Position = push.world_to_clip * vec4(in_position, 1.0);
  out_position = in_position;
  out_normal = in_normal;
}
