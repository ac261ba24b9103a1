#version 460
// The interleaved gather's reconstruction filter (include/indirect_filter.glsl).
#include "indirect_filter.glsl"
