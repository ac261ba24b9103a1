#version 460
// The crease kernel (include/indirect_creases.glsl) with ISMs that keep back-face maps
// (RenderSettings::ism_back_faces): a receiver beyond a flagged texel's
// back face is hidden (ism_behind_back_face in vpl_gather.glsl).
#define ISM_BACK_FACES
#include "indirect_creases.glsl"
