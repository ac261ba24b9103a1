#version 460
// G-buffer layer 1 by depth peeling (see include/gbuffer_frag.glsl).
#define PEEL
#include "gbuffer_frag.glsl"
