#version 460
// The full gather (include/indirect_bounded.glsl) with ISM visibility.
#include "indirect_bounded.glsl"
