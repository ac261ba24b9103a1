#version 460
// The post-process's result into a host image of format rgba32f
// (include/postprocess_write.glsl).
#define OUTPUT_FORMAT rgba32f
#include "postprocess_write.glsl"
