#version 460
// G-buffer: world position (w = 1 on geometry), normal facing the camera,
// linear albedo.
#include "common.glsl"

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 3) flat in uint v_material;

layout(push_constant) uniform Push {
    mat4 view_proj;
    vec4 camera_position;
} pc;

layout(set = 0, binding = 0) readonly buffer Materials { GpuMaterial materials[]; };
layout(set = 0, binding = 1) uniform sampler2DArray base_color_textures;

layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_albedo;

void main() {
    GpuMaterial m = materials[v_material];
    vec3 albedo = m.base_color.rgb;
    if (m.texture.x >= 0) {
        albedo *= texture(base_color_textures, vec3(v_uv, float(m.texture.x))).rgb;
    }
    vec3 n = normalize(v_normal);
    // Two-sided shading: the normal faces the viewer.
    if (dot(n, pc.camera_position.xyz - v_position) < 0.0) {
        n = -n;
    }
    out_position = vec4(v_position, 1.0);
    out_normal = vec4(n, 0.0);
    out_albedo = vec4(albedo, 1.0);
}
