#ifndef HOLOFUSE_VERTICES_GLSL
#define HOLOFUSE_VERTICES_GLSL
// The mesh's vertices (C++: Renderer::setMesh), read by the compute passes
// and the blend's vertex stage alike. Full precision: six floats per
// vertex, position then normal. With blend.counts.w = 1, half precision
// (paper 000's memory saving): the six values as halves, two to a word,
// three words per vertex; unpacking gives the same floats a full-precision
// buffer of the rounded values would hold.
layout(std430, set = 0, binding = HOLOFUSE_BINDING_VERTICES) readonly buffer Vertices { uint vertex_words[]; };

vec3 vertexPosition(uint v) {
  if (blend.counts.w != 0) {
    vec2 xy = unpackHalf2x16(vertex_words[3u * v]);
    return vec3(xy, unpackHalf2x16(vertex_words[3u * v + 1u]).x);
  }
  return uintBitsToFloat(uvec3(vertex_words[6u * v], vertex_words[6u * v + 1u], vertex_words[6u * v + 2u]));
}

vec3 vertexNormal(uint v) {
  if (blend.counts.w != 0) {
    return vec3(unpackHalf2x16(vertex_words[3u * v + 1u]).y, unpackHalf2x16(vertex_words[3u * v + 2u]));
  }
  return uintBitsToFloat(uvec3(vertex_words[6u * v + 3u], vertex_words[6u * v + 4u], vertex_words[6u * v + 5u]));
}
#endif
