#version 460
// ISM point splatting (include/ism_splat.glsl) into the front map and, for
// points seen from behind, the back-face map too (ism_back_texel).
#define ISM_BACK_FACES
#include "ism_splat.glsl"
