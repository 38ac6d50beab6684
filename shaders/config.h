// Limits and layouts shared by GLSL and C++ (included by both).
#ifndef HOLOFUSE_SHADER_CONFIG_H
#define HOLOFUSE_SHADER_CONFIG_H

#define HOLOFUSE_MAX_CAMERAS 16
// Blending modes (render_client/include/render_client/blend_mode.h).
#define HOLOFUSE_MODE_NORMAL 0

#endif
