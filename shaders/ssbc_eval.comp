#version 460
// SSBC evaluation points (include/ssbc_eval.glsl).
#include "ssbc_eval.glsl"
