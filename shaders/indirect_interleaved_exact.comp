#version 460
// The interleaved gather (include/indirect_interleaved.glsl) with exact visibility: ray queries against
// the scene's acceleration structures.
#extension GL_EXT_ray_query : require
#define EXACT_VISIBILITY
#include "indirect_interleaved.glsl"
