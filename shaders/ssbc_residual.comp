#version 460
// One SSBC step: S_k(x) = sum_y max(G(x,y) - b, 0) A_y f_r(x) S_{k-1}(y), over
// the screen-space neighbourhood where G can exceed b (|x - y| < 1/sqrt(b)).
// Hierarchical (mode 0): top-down over the pyramids, skipping texels that
// cannot reach b, refining discontinuous or too-close texels, adding the
// rest from their averages; the finest level always adds. Brute force
// (mode 1): every full-resolution pixel of the window.
#include "common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D g_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D g_albedo;
layout(set = 0, binding = 3) uniform sampler2D geo_position;   // xyz mean position, w summed area
layout(set = 0, binding = 4) uniform sampler2D geo_normal;     // xyz mean normal, w discontinuity
layout(set = 0, binding = 5) uniform sampler2D radiance;       // rgb mean S_{k-1}
layout(set = 0, binding = 6) uniform sampler2D geo_extent;     // x bounding radius around the mean, y slab half-thickness along the mean normal
layout(set = 0, binding = 7, rgba32f) uniform writeonly image2D residual;
layout(set = 0, binding = 8, r32ui) uniform writeonly uimage2D samples;
layout(set = 0, binding = 9) buffer Stats { uint stack_overflows; };

layout(push_constant) uniform Push {
    vec4 camera_position;   // xyz eye
    vec4 camera_forward;    // xyz optical axis, w focal length in pixels
    uvec2 size;
    uvec2 pyramid_size;     // level 0 of the pyramids (padded so every level halves exactly)
    uint levels;
    uint mode;
    float bound;            // b [1/m^2]
    float refine_ratio;     // refine a texel whose extent exceeds this fraction of its distance
} pc;

// Texels of pyramid level l. (Computed, not textureSize(): lavapipe returned
// zero sizes for a non-constant lod.)
ivec2 level_size(int l) {
    return max(ivec2(pc.pyramid_size) >> l, ivec2(1));
}

const int STACK_SIZE = 64;

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(pixel), pc.size))) return;
    vec4 xp = imageLoad(g_position, pixel);
    // G <= 1/d^2, so only |x - y| < 1/sqrt(b) can exceed b.
    float r_world = inversesqrt(pc.bound);
    if (xp.w == 0.0 || !(r_world > 0.0)) {
        imageStore(residual, pixel, vec4(0.0, 0.0, 0.0, xp.w));
        imageStore(samples, pixel, uvec4(0u));
        return;
    }
    vec3 x = xp.xyz;
    vec3 nx = imageLoad(g_normal, pixel).xyz;

    // Conservative screen radius of the sphere of radius r_world around x.
    vec3 v = x - pc.camera_position.xyz;
    float z = dot(v, pc.camera_forward.xyz);
    float cos_alpha = z / length(v);
    float radius_px = float(max(pc.size.x, pc.size.y));
    if (z - r_world > 1e-4) {
        radius_px = min(radius_px, pc.camera_forward.w * r_world / ((z - r_world) * cos_alpha * cos_alpha) + 1.0);
    }

    vec3 sum = vec3(0.0);
    uint count = 0u;
    if (pc.mode == 1u) {
        ivec2 lo = max(pixel - ivec2(ceil(radius_px)), ivec2(0));
        ivec2 hi = min(pixel + ivec2(ceil(radius_px)), ivec2(pc.size) - 1);
        for (int py = lo.y; py <= hi.y; py++) {
            for (int px = lo.x; px <= hi.x; px++) {
                count++;
                vec4 yp = texelFetch(geo_position, ivec2(px, py), 0);
                vec3 d = yp.xyz - x;
                float d2 = dot(d, d);
                if (yp.w == 0.0 || d2 >= r_world * r_world || d2 < 1e-12) continue;
                vec3 w = d * inversesqrt(d2);
                float g = max(dot(nx, w), 0.0) * max(-dot(texelFetch(geo_normal, ivec2(px, py), 0).xyz, w), 0.0) / d2;
                sum += max(g - pc.bound, 0.0) * yp.w * texelFetch(radiance, ivec2(px, py), 0).rgb;
            }
        }
    } else {
        // Coarsest level whose texels are about half the radius.
        int top = int(pc.levels) - 1;
        int level = clamp(int(ceil(log2(max(radius_px, 1.0) * 0.5))), 0, top);
        ivec2 lo = max((pixel - ivec2(ceil(radius_px))) >> level, ivec2(0));
        ivec2 hi = min((pixel + ivec2(ceil(radius_px))) >> level, level_size(level) - 1);
        ivec3 stack[STACK_SIZE];
        for (int ty = lo.y; ty <= hi.y; ty++) {
            for (int tx = lo.x; tx <= hi.x; tx++) {
                int top_of_stack = 0;
                stack[top_of_stack++] = ivec3(tx, ty, level);
                while (top_of_stack > 0) {
                    ivec3 t = stack[--top_of_stack];
                    count++;
                    vec4 yp = texelFetch(geo_position, t.xy, t.z);
                    if (yp.w == 0.0) continue;
                    vec3 d = yp.xyz - x;
                    float dist = length(d);
                    // Sphere (radius `extent`) and slab (half-thickness along the
                    // mean normal) holding all of the texel's surface.
                    vec2 bounds = texelFetch(geo_extent, t.xy, t.z).xy;
                    float extent = bounds.x;
                    vec4 yn = texelFetch(geo_normal, t.xy, t.z);
                    // Skip texels where G cannot exceed b anywhere: G <= cos_x / d^2 with
                    // d >= dist - extent, and n_x . (y - x) <= n_x . d + |a| thickness
                    // + sqrt(1 - a^2) extent for every y in the texel (a = n_x . n_mean).
                    float d_min = dist - extent;
                    if (d_min >= r_world) continue;
                    if (d_min > 0.0) {
                        float a = clamp(dot(nx, yn.xyz), -1.0, 1.0);
                        float reach = dot(nx, d) + abs(a) * bounds.y + sqrt(1.0 - a * a) * extent;
                        float cos_x_max = min(1.0, reach / d_min);
                        if (cos_x_max <= 0.0 || cos_x_max <= pc.bound * d_min * d_min) continue;
                    }
                    // Refine discontinuous texels and texels too large for their distance.
                    bool refine = t.z > 0 && (yn.w > 0.5 || extent > pc.refine_ratio * dist);
                    if (refine) {
                        if (top_of_stack + 4 <= STACK_SIZE) {
                            ivec2 finer = level_size(t.z - 1);
                            for (int k = 0; k < 4; k++) {
                                ivec2 c = t.xy * 2 + ivec2(k & 1, k >> 1);
                                if (all(lessThan(c, finer))) stack[top_of_stack++] = ivec3(c, t.z - 1);
                            }
                            continue;
                        }
                        atomicAdd(stack_overflows, 1u);  // counted and reported; the texel is added as is
                    }
                    if (dist < 1e-6) continue;
                    vec3 w = d / dist;
                    float g = max(dot(nx, w), 0.0) * max(-dot(yn.xyz, w), 0.0) / (dist * dist);
                    sum += max(g - pc.bound, 0.0) * yp.w * texelFetch(radiance, t.xy, t.z).rgb;
                }
            }
        }
    }
    vec3 albedo = imageLoad(g_albedo, pixel).rgb;
    imageStore(residual, pixel, vec4(albedo / PI * sum, xp.w));
    imageStore(samples, pixel, uvec4(count));
}
