#version 460
// The full gather (include/indirect_bounded.glsl) with exact visibility: ray queries against
// the scene's acceleration structures.
#extension GL_EXT_ray_query : require
#define EXACT_VISIBILITY
#include "indirect_bounded.glsl"
