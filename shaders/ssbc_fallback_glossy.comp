#version 460
// SSBC fallback at glossy receivers (ssbc_fallback.comp lists them).
#define SSBC_GLOSSY_FALLBACK
#include "ssbc_fallback.glsl"
