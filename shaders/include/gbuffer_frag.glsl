// G-buffer fragment shader (gbuffer.frag, and gbuffer_peel.frag with PEEL
// defined): world position (w = 1 on geometry), shading normal (normal-
// mapped), linear albedo, and the radiance emitted towards the camera.
// Texels below an alpha mask's cutoff are discarded. Layer 0 (the visible
// surfaces): a one-sided surface seen from behind (the side its vertex
// normals do not point to) is culled, and the normal faces the camera.
// Layer 1 (PEEL, a deep G-buffer's second layer, Mara et al. 2016): only
// fragments at least a separation (camera_position.w) farther from the
// camera than layer 0 at their pixel pass, back faces included, with the
// normal of the side the vertex normals point to (hidden faces of closed
// objects face away from the camera, towards what they light). The CPU twin
// is src/cpu/bvh.rs (SceneBvh::surface).
#ifndef SSBC_GBUFFER_FRAG_GLSL
#define SSBC_GBUFFER_FRAG_GLSL
#include "common.glsl"
#include "geometric_normal.glsl"

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 3) flat in uint v_material;
layout(location = 4) in vec4 v_tangent;
layout(location = 5) in vec4 v_color;

layout(push_constant) uniform Push {
    mat4 view_proj;
    vec4 camera_position;  // xyz eye; w (PEEL) the separation behind layer 0 [m]
    uint layer1_shift;     // (PEEL) log2 of layer 1's pixel side in layer-0 pixels (0 or 1)
} pc;

layout(set = 0, binding = 0) readonly buffer Materials { GpuMaterial materials[]; };
layout(set = 0, binding = 1) uniform sampler2DArray color_textures;
layout(set = 0, binding = 2) uniform sampler2DArray linear_textures;

#include "material.glsl"

// (metallic, roughness, specular layer) of m at uv: factors times the
// metallic-roughness map's B and G channels (averaged over the footprint).
vec3 material_reflectance(GpuMaterial m, vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    vec3 r = m.normal.yzw;
    int layer = (m.textures.w >> 1) - 1;
    if (layer >= 0) {
        map_uv(m, UV_REFLECTANCE, uv, duv_dx, duv_dy);
        vec4 t = sample_texture(linear_textures, layer, m.samplers.w, uv, duv_dx, duv_dy);
        r.x *= t.b;
        r.y *= t.g;
    }
    return r;
}

#ifdef PEEL
// Layer 0 at full resolution: a layer-1 pixel p covers its pixels
// p << shift .. ((p + 1) << shift) - 1.
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D layer0_position;

// Whether the fragment lies at least the separation behind layer 0 at all
// the (geometry) pixels of layer 0 under it.
bool behind_layer0() {
    int side = 1 << pc.layer1_shift;
    ivec2 base = ivec2(gl_FragCoord.xy) * side;
    ivec2 size = imageSize(layer0_position);
    float eye = distance(v_position, pc.camera_position.xyz);
    bool any_geometry = false;
    bool behind = true;
    for (int k = 0; k < side * side; k++) {
        ivec2 q = min(base + ivec2(k % side, k / side), size - 1);
        vec4 first = imageLoad(layer0_position, q);
        if (first.w != 0.0) {
            any_geometry = true;
            behind = behind && eye > distance(first.xyz, pc.camera_position.xyz) + pc.camera_position.w;
        }
    }
    return any_geometry && behind;
}
#endif

layout(location = 0) out vec4 out_position;
layout(location = 1) out uvec2 out_normal;  // pack_gbuffer_normal (common.glsl)
layout(location = 2) out uvec2 out_albedo;  // pack_gbuffer_albedo
layout(location = 3) out vec4 out_emission;

void main() {
    // The pixel's footprint on the textures (before any discard: helper
    // lanes are needed for derivatives).
    vec2 duv_dx = dFdx(v_uv);
    vec2 duv_dy = dFdy(v_uv);
    GpuMaterial m = materials[v_material];
    if (!material_opaque(m, v_uv, v_color)) discard;
#ifdef PEEL
    if (!behind_layer0()) discard;
#endif
    vec3 n = normalize(v_normal);
    bool front = dot(n, pc.camera_position.xyz - v_position) >= 0.0;
#ifndef PEEL
    if (!front && !material_double_sided(m)) discard;
#endif
    // Normal map in the frame of the interpolated tangent: the direction of
    // the footprint's mean normal. (Widening the GGX lobe by the normals'
    // spread, Toksvig's alpha^2 + 2 (1 - r) / r, made minified bumpy metal
    // worse: GGX's long tail is no Gaussian's, docs/accuracy.md.)
    vec3 geometric = n;
    bool mapped_normal = false;
    vec3 t = v_tangent.xyz - n * dot(n, v_tangent.xyz);
    if (m.textures.z >= 0 && dot(t, t) > 1e-12) {
        vec2 uv = v_uv;
        vec2 dx = duv_dx;
        vec2 dy = duv_dy;
        map_uv(m, UV_NORMAL, uv, dx, dy);
        vec3 tex = sample_texture(linear_textures, m.textures.z, m.samplers.z, uv, dx, dy).xyz * 2.0 - 1.0;
        vec3 local = vec3(tex.xy * m.normal.x, tex.z);
        t = normalize(t);
        vec3 b = cross(n, t) * (v_tangent.w < 0.0 ? -1.0 : 1.0);
        vec3 mapped = t * local.x + b * local.y + n * local.z;
        if (dot(mapped, mapped) > 0.0) n = normalize(mapped);
        mapped_normal = true;
    }
#ifndef PEEL
    // Two-sided shading: the normal faces the viewer.
    if (!front) {
        n = -n;
        geometric = -geometric;
    }
#endif
    // The BRDF as brdf_from_gbuffer reads it: metallic in albedo.w,
    // roughness in normal.w (-1: Lambertian).
    vec3 reflectance = material_reflectance(m, v_uv, duv_dx, duv_dy);
    bool lambertian = reflectance.z == 0.0 && reflectance.x == 0.0;
    out_position = vec4(v_position, 1.0);
    out_normal = pack_gbuffer_normal(vec4(n, lambertian ? -1.0 : reflectance.y));
    out_albedo = pack_gbuffer_albedo(vec4(material_base_color(m, v_uv, duv_dx, duv_dy, v_color).rgb, reflectance.x));
    // w: the geometric normal where the normal map turned n (geometric_normal.glsl).
    out_emission = vec4(material_emission(m, v_uv, duv_dx, duv_dy), mapped_normal ? encode_geometric_normal(geometric) : 1.0);
}

#endif
