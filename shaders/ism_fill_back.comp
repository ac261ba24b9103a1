#version 460
// ISM hole filling (include/ism_fill.glsl) that also flags the front
// texels whose back-face map the gathers' test needs (ISM_BACK_FLAG).
#define ISM_BACK_FACES
#include "ism_fill.glsl"
