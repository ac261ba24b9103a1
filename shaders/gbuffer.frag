#version 460
// G-buffer layer 0: the visible surfaces (see include/gbuffer_frag.glsl).
#include "gbuffer_frag.glsl"
