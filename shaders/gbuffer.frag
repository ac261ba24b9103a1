#version 460
// G-buffer: world position (w = 1 on geometry), shading normal facing the
// camera (normal-mapped), linear albedo, and the radiance emitted towards the
// camera. Texels below an alpha mask's cutoff are discarded; a one-sided
// surface seen from behind (the side its vertex normals do not point to) is
// culled. The CPU twin is src/cpu/bvh.rs (SceneBvh::surface).
#include "common.glsl"

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 3) flat in uint v_material;
layout(location = 4) in vec4 v_tangent;

layout(push_constant) uniform Push {
    mat4 view_proj;
    vec4 camera_position;
} pc;

layout(set = 0, binding = 0) readonly buffer Materials { GpuMaterial materials[]; };
layout(set = 0, binding = 1) uniform sampler2DArray color_textures;
layout(set = 0, binding = 2) uniform sampler2DArray linear_textures;

#include "material.glsl"

layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_albedo;
layout(location = 3) out vec4 out_emission;

void main() {
    GpuMaterial m = materials[v_material];
    if (!material_opaque(m, v_uv)) discard;
    vec3 n = normalize(v_normal);
    bool front = dot(n, pc.camera_position.xyz - v_position) >= 0.0;
    if (!front && !material_double_sided(m)) discard;
    // Normal map in the frame of the interpolated tangent.
    vec3 t = v_tangent.xyz - n * dot(n, v_tangent.xyz);
    if (m.textures.z >= 0 && dot(t, t) > 1e-12) {
        vec3 tex = sample_texture(linear_textures, m.textures.z, m.samplers.z, v_uv).xyz * 2.0 - 1.0;
        vec3 local = vec3(tex.xy * m.normal.x, tex.z);
        t = normalize(t);
        vec3 b = cross(n, t) * (v_tangent.w < 0.0 ? -1.0 : 1.0);
        vec3 mapped = t * local.x + b * local.y + n * local.z;
        if (dot(mapped, mapped) > 0.0) n = normalize(mapped);
    }
    // Two-sided shading: the normal faces the viewer.
    if (!front) n = -n;
    out_position = vec4(v_position, 1.0);
    out_normal = vec4(n, 0.0);
    out_albedo = vec4(material_base_color(m, v_uv).rgb, 1.0);
    out_emission = vec4(material_emission(m, v_uv), 1.0);
}
