#version 460
// The post-process's result into a host image of format rgba16f
// (include/postprocess_write.glsl).
#define OUTPUT_FORMAT rgba16f
#include "postprocess_write.glsl"
