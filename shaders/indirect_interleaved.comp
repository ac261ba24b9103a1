#version 460
// The interleaved gather (include/indirect_interleaved.glsl) with ISM visibility.
#include "indirect_interleaved.glsl"
