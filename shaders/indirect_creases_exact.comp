#version 460
// The crease kernel (include/indirect_creases.glsl) with exact visibility: ray queries against
// the scene's acceleration structures.
#extension GL_EXT_ray_query : require
#define EXACT_VISIBILITY
#include "indirect_creases.glsl"
