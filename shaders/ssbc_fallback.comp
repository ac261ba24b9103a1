#version 460
// SSBC fallback (include/ssbc_fallback.glsl).
#include "ssbc_fallback.glsl"
