#version 460
// SSBC geometry pyramid. Mode 0 builds level 0 from the G-buffer: world
// position and the world-space area A_y seen through the pixel,
//   A_y = t^2 * Omega_px / max(cos theta_view, min_cos_view),
//   Omega_px = s^2 cos^3(alpha)   (s: pixel side on the image plane at distance 1),
// and the normal. Mode 1 builds level l from l-1: summed area, area-weighted
// mean position and normal, and the discontinuity flag (children that mix
// background and geometry, are not close to one plane, or disagree in normal).

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D g_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D src_position;  // level l-1: xyz mean position, w area
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D src_normal;    // level l-1: xyz mean normal, w discontinuity
layout(set = 0, binding = 4, rg32f) uniform readonly image2D src_extent;      // level l-1: x bounding radius, y slab half-thickness
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D dst_position;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D dst_normal;
layout(set = 0, binding = 7, rg32f) uniform writeonly image2D dst_extent;

layout(push_constant) uniform Push {
    vec4 camera_position;   // xyz eye
    vec4 camera_forward;    // xyz optical axis, w pixel side s at distance 1
    uvec2 dst_size;
    uvec2 gbuffer_size;
    uint mode;
    float min_cos_view;
    float max_normal_spread;  // children whose normals' cosine to the mean is below this are discontinuous
    float max_thickness;      // a texel whose slab is thicker than this x its radius is discontinuous
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.dst_size))) return;
    if (pc.mode == 0u) {
        vec4 pos = vec4(0.0);
        vec3 n = vec3(0.0);
        if (all(lessThan(uvec2(p), pc.gbuffer_size))) {
            pos = imageLoad(g_position, p);
            n = imageLoad(g_normal, p).xyz;
        }
        float area = 0.0;
        if (pos.w != 0.0) {
            vec3 v = pos.xyz - pc.camera_position.xyz;
            float t = length(v);
            vec3 dir = v / t;
            float cos_alpha = dot(dir, pc.camera_forward.xyz);
            float s = pc.camera_forward.w;
            float omega = s * s * cos_alpha * cos_alpha * cos_alpha;
            float cos_view = max(abs(dot(n, dir)), pc.min_cos_view);
            area = t * t * omega / cos_view;
        }
        imageStore(dst_position, p, vec4(pos.xyz, area));
        imageStore(dst_normal, p, vec4(n, 0.0));
        imageStore(dst_extent, p, vec4(0.0));
        return;
    }
    vec4 cp[4];
    vec4 cn[4];
    vec2 cr[4];
    float area = 0.0;
    vec3 position = vec3(0.0);
    vec3 normal = vec3(0.0);
    int geometry = 0;
    int empty = 0;
    bool discontinuous = false;
    for (int k = 0; k < 4; k++) {
        ivec2 c = p * 2 + ivec2(k & 1, k >> 1);
        cp[k] = imageLoad(src_position, c);
        cn[k] = imageLoad(src_normal, c);
        cr[k] = imageLoad(src_extent, c).xy;
        if (cp[k].w > 0.0) {
            geometry++;
            area += cp[k].w;
            position += cp[k].w * cp[k].xyz;
            normal += cp[k].w * cn[k].xyz;
            discontinuous = discontinuous || cn[k].w > 0.5;
        } else {
            empty++;
        }
    }
    // Bounding sphere (radius) and slab (half-thickness along the mean normal)
    // of every pixel position below: |y - mean| <= radius and
    // |n . (y - mean)| <= thickness. A child's slab projected onto n adds
    // |a| thickness_c + sqrt(1 - a^2) radius_c, with a = n . n_c.
    float radius = 0.0;
    float thickness = 0.0;
    if (area > 0.0) {
        position /= area;
        float len = length(normal);
        normal = len > 0.0 ? normal / len : cn[0].xyz;
        for (int k = 0; k < 4; k++) {
            if (cp[k].w > 0.0) {
                vec3 offset = cp[k].xyz - position;
                float dist = length(offset);
                float a = clamp(dot(normal, cn[k].xyz), -1.0, 1.0);
                radius = max(radius, dist + cr[k].x);
                thickness = max(thickness, abs(dot(normal, offset)) + abs(a) * cr[k].y + sqrt(1.0 - a * a) * cr[k].x);
                discontinuous = discontinuous || a < pc.max_normal_spread;
            }
        }
    }
    // A depth step (children far from one plane) or a mix of background and
    // geometry is a discontinuity too. The slab test does not depend on the
    // viewing angle, so grazing planes stay continuous.
    discontinuous = discontinuous || thickness > pc.max_thickness * radius || (geometry > 0 && empty > 0);
    imageStore(dst_position, p, vec4(position, area));
    imageStore(dst_normal, p, vec4(normal, discontinuous ? 1.0 : 0.0));
    imageStore(dst_extent, p, vec4(radius, thickness, 0.0, 0.0));
}
