#version 460
// The interleaved gather (include/indirect_interleaved.glsl) with ISMs that keep back-face maps
// (RenderSettings::ism_back_faces): a receiver beyond a flagged texel's
// back face is hidden (ism_behind_back_face in vpl_gather.glsl).
#define ISM_BACK_FACES
#include "indirect_interleaved.glsl"
