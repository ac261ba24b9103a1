#version 460
// The crease kernel (include/indirect_creases.glsl) with ISM visibility.
#include "indirect_creases.glsl"
