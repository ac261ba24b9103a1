// Bounded VPL lighting T_b L^ by the full gather: every VPL at every pixel,
// f_r(x) min(G, b) V_ISM f_r(z) Phi summed (the reference of the
// interleaved gather), as S0 = direct + bounded indirect, the term SSBC
// compensates; adds what each pixel sends as an SSBC source
// (brdf_source_color) to the direct light's (s0_sources is that image).
#include "common.glsl"
#include "ism.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rg32ui) uniform readonly uimage2D g_normal;
layout(set = 0, binding = 2, rg32ui) uniform readonly uimage2D g_albedo;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D direct;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D s0;
layout(set = 0, binding = 6) uniform textureBuffer vpl_texels;
layout(set = 0, binding = 7, r32ui) uniform readonly uimage2D ism; // ism_pack()ed texels
layout(set = 0, binding = 8, rgba32f) uniform readonly image2D direct_sources;
layout(set = 0, binding = 9, rgba32f) uniform writeonly image2D s0_sources;
layout(set = 0, binding = 10, rgba32f) uniform readonly image2D g_emission; // w: geometric normal

#include "gather_push.glsl"

#include "vpl_gather.glsl"

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(pixel), pc.size))) return;
    vec4 position = imageLoad(g_position, pixel);
    vec4 direct_radiance = imageLoad(direct, pixel);
    vec3 radiance = vec3(0.0);
    vec3 source = vec3(0.0);
    if (position.w != 0.0) {
        vec4 n = unpack_gbuffer_normal(imageLoad(g_normal, pixel));
        Brdf b = brdf_from_gbuffer(unpack_gbuffer_albedo(imageLoad(g_albedo, pixel)), n);
        vec3 wo = normalize(pc.camera_position.xyz - position.xyz);
        vec3 ng = geometric_normal(imageLoad(g_emission, pixel).w, n.xyz);
        VplLight light = vpl_sum(position.xyz, n.xyz, ng, b, wo, 0u, pc.count, 1u);
        radiance = brdf_diffuse_color(b) / PI * light.irradiance + light.glossy;
        source = brdf_source_color(b) / PI * light.irradiance;
    }
    imageStore(s0, pixel, vec4(direct_radiance.rgb + radiance, position.w));
    vec4 own = imageLoad(direct_sources, pixel);  // w: the geometric normal, kept
    imageStore(s0_sources, pixel, vec4(own.rgb + source, own.w));
}
