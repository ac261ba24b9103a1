// The interleaved gather of the bounded VPL lighting (Keller & Heidrich
// 2001): the VPLs come sorted into N x N random subsets, and each pixel of
// an N x N block evaluates one subset, the one of its position in the
// block. The dispatch is de-interleaved: work group z = subset, so a
// group's invocations share one subset and loop over the same VPLs. It
// writes N^2 x its subset's sum, packed (`pack_sums` in interleaved_sums.glsl): the
// diffuse part without the receiver's diffuse colour, the glossy rest, and
// the mean widening of its lobe by the VPLs' radii (vpl_gather.glsl).
#include "common.glsl"
#include "ism.glsl"
#include "interleaved_sums.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rg32ui) uniform readonly uimage2D g_normal;
layout(set = 0, binding = 2) uniform textureBuffer vpl_texels;
layout(set = 0, binding = 3, r32ui) uniform readonly uimage2D ism; // ism_pack()ed texels
layout(set = 0, binding = 4) readonly buffer Subsets { uint subset_start[]; };
layout(set = 0, binding = 5, rgba32ui) uniform writeonly uimage2D interleaved;  // pack_sums
layout(set = 0, binding = 7, rg32ui) uniform readonly uimage2D g_albedo;
layout(set = 0, binding = 9, rgba32f) uniform readonly image2D g_emission; // w: geometric normal

#include "gather_push.glsl"

#include "vpl_gather.glsl"

void main() {
    uint subset = gl_WorkGroupID.z;
    uvec2 in_block = uvec2(subset % pc.count, subset / pc.count);
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy * pc.count + in_block);
    if (any(greaterThanEqual(uvec2(pixel), pc.size))) return;
    vec4 position = imageLoad(g_position, pixel);
    if (position.w == 0.0) {
        imageStore(interleaved, pixel, uvec4(0u));
        return;
    }
    vec4 n = unpack_gbuffer_normal(imageLoad(g_normal, pixel));
    Brdf b = brdf_from_gbuffer(unpack_gbuffer_albedo(imageLoad(g_albedo, pixel)), n);
    vec3 wo = normalize(pc.camera_position.xyz - position.xyz);
    vec3 ng = geometric_normal(imageLoad(g_emission, pixel).w, n.xyz);
    VplLight light = vpl_sum(position.xyz, n.xyz, ng, b, wo, subset_start[subset], subset_start[subset + 1u], 1u);
    float subsets = float(pc.count * pc.count);
    imageStore(interleaved, pixel, pack_sums(light.irradiance * (subsets / PI), light.glossy * subsets, light.spread2));
}
