#version 460
// SSBC evaluation points in frames with glossy receivers
// (include/ssbc_eval.glsl).
#define SSBC_GLOSSY_POINTS
#include "ssbc_eval.glsl"
