#version 460
// Shadow map: cut-out texels of alpha-masked materials cast no shadow.
#include "common.glsl"

layout(location = 0) in vec2 v_uv;
layout(location = 1) flat in uint v_material;
layout(location = 2) in vec4 v_color;

layout(set = 0, binding = 0) readonly buffer Materials { GpuMaterial materials[]; };
layout(set = 0, binding = 1) uniform sampler2DArray color_textures;

#include "material.glsl"

void main() {
    if (!material_opaque(materials[v_material], v_uv, v_color)) discard;
}
