#version 460
// ISM point splatting into the front map (include/ism_splat.glsl).
#include "ism_splat.glsl"
