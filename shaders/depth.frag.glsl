#version 450
layout(location = 0) in float in_depth;
layout(location = 0) out float out_depth;
void main() { out_depth = in_depth; }
