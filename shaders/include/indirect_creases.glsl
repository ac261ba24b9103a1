// The interleaved gather's exception: pixels beside a crease or contact
// (indirect_filter.comp lists them) evaluate every VPL themselves. There
// the bounded lighting changes within a pixel (the geometry term of VPLs
// on the adjoining surface drops to zero at the crease line), so sums
// borrowed from neighbours, however close, would be wrong. Writes S0 and
// its sources at those pixels (the filter skipped them).
//
// A workgroup takes 8 listed pixels (x) with 16 lanes each (y), a lane
// summing every 16th VPL. A thread per pixel left a GPU nearly idle (a few
// thousand threads, each looping over thousands of VPLs) (measured: docs/accuracy.md, "Tuned constants").
// Lanes of one VPL slice run side by side (x first), so a CPU's SIMD
// rows still fetch one VPL for 8 pixels.
#include "common.glsl"
#include "ism.glsl"

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rg32ui) uniform readonly uimage2D g_normal;
layout(set = 0, binding = 2, rg32ui) uniform readonly uimage2D g_albedo;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D direct;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D s0;
layout(set = 0, binding = 6) uniform textureBuffer vpl_texels;
layout(set = 0, binding = 7, r32ui) uniform readonly uimage2D ism; // ism_pack()ed texels
// (dispatch x, y, z, count), then x | y << 16 per pixel.
layout(set = 0, binding = 8) readonly buffer Creases { uvec4 header; uint pixels[]; } creases;
layout(set = 0, binding = 9, rgba32f) uniform readonly image2D direct_sources;
layout(set = 0, binding = 10, rgba32f) uniform writeonly image2D s0_sources;
layout(set = 0, binding = 11, rgba32f) uniform readonly image2D g_emission; // w: geometric normal

#include "gather_push.glsl"

#include "vpl_gather.glsl"

const uint PIXELS = 8u;
const uint LANES = 16u;
layout(local_size_x = 8, local_size_y = 16) in;
shared vec3 lane_irradiance[LANES][PIXELS];
shared vec3 lane_glossy[LANES][PIXELS];

void main() {
    uint px = gl_LocalInvocationID.x;
    uint lane = gl_LocalInvocationID.y;
    // Uniform per group (barriers below). (The count is read once: a
    // buffer read in the loop's header made GPU-assisted validation's
    // instrumented SPIR-V invalid.)
    uint count = creases.header.w;
    for (uint base = gl_WorkGroupID.x * PIXELS; base < count; base += gl_NumWorkGroups.x * PIXELS) {
        uint item = base + px;
        ivec2 pixel = ivec2(0);
        Brdf b;
        VplLight light = VplLight(vec3(0.0), vec3(0.0), 0.0);
        if (item < count) {
            uint packed = creases.pixels[item];
            pixel = ivec2(packed & 0xFFFFu, packed >> 16);
            vec3 x = imageLoad(g_position, pixel).xyz;
            vec4 n = unpack_gbuffer_normal(imageLoad(g_normal, pixel));
            b = brdf_from_gbuffer(unpack_gbuffer_albedo(imageLoad(g_albedo, pixel)), n);
            vec3 wo = normalize(pc.camera_position.xyz - x);
            vec3 ng = geometric_normal(imageLoad(g_emission, pixel).w, n.xyz);
            light = vpl_sum(x, n.xyz, ng, b, wo, lane, pc.count, LANES);
        }
        lane_irradiance[lane][px] = light.irradiance;
        lane_glossy[lane][px] = light.glossy;
        barrier();
        for (uint half_width = LANES / 2u; half_width > 0u; half_width /= 2u) {
            if (lane < half_width) {
                lane_irradiance[lane][px] += lane_irradiance[lane + half_width][px];
                lane_glossy[lane][px] += lane_glossy[lane + half_width][px];
            }
            barrier();
        }
        if (lane == 0u && item < count) {
            vec3 irradiance = lane_irradiance[0][px];
            vec3 radiance = brdf_diffuse_color(b) / PI * irradiance + lane_glossy[0][px];
            vec3 source = brdf_source_color(b) / PI * irradiance;
            imageStore(s0, pixel, vec4(imageLoad(direct, pixel).rgb + radiance, 1.0));
            vec4 own = imageLoad(direct_sources, pixel);  // w: the geometric normal, kept
            imageStore(s0_sources, pixel, vec4(own.rgb + source, own.w));
        }
        // The sums are read before the next pixels overwrite them.
        barrier();
    }
}
