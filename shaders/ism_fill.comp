#version 460
// ISM hole filling (include/ism_fill.glsl).
#include "ism_fill.glsl"
