#version 460
// The interleaved gather's reconstruction filter (include/indirect_filter.glsl)
// with exact visibility: neighbours a surface separates from the pixel do
// not count as its surface.
#extension GL_EXT_ray_query : require
#define EXACT_VISIBILITY
#include "indirect_filter.glsl"
