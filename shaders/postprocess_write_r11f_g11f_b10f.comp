#version 460
// The post-process's result into a host image of format r11f_g11f_b10f
// (include/postprocess_write.glsl).
#define OUTPUT_FORMAT r11f_g11f_b10f
#include "postprocess_write.glsl"
