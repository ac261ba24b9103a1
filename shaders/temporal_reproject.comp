#version 460
// Temporal history, step 1: the previous frame's history of indirect light,
// reprojected into this frame. Each pixel's surface point is projected with
// the previous view; of the four history pixels around it, those that saw
// the same surface (normal within ~25 degrees, on the pixel's tangent plane,
// the same material) are blended bilinearly. None: the surface was not seen
// (disocclusion, the image border) and the pixel starts anew (alpha 0).
// A glossy surface's light depends on the view: its history's frames are
// cut by how far the view direction turned against its lobe's width.

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rg32ui) uniform readonly uimage2D g_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D previous_position;
layout(set = 0, binding = 3, rg32ui) uniform readonly uimage2D previous_normal;
// rgb: the previous frame's mean indirect light; a: frames it averages.
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D previous_history;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D reprojected;
layout(set = 0, binding = 6, rg32ui) uniform readonly uimage2D g_albedo;
layout(set = 0, binding = 7, rg32ui) uniform readonly uimage2D previous_albedo;

layout(push_constant) uniform Push {
    mat4 previous_view_proj;   // world to clip space of the previous frame
    vec4 camera_position;      // xyz: this frame's eye
    vec4 previous_camera;      // xyz: the previous frame's eye
    uvec2 size;
    uint has_history;          // 0: every pixel starts anew
} pc;

const float MIN_NORMAL_COS = 0.9;
// A history pixel is on the same surface when it lies within this fraction
// of the distance to the eye from the pixel's tangent plane.
const float MAX_PLANE = 0.01;
// Materials differ when base colour, metalness or roughness differ by more.
const float MAX_MATERIAL = 0.05;

#include "brdf.glsl"

// Whether two G-buffer materials (albedo: base colour + metallic; normal.w:
// roughness, -1 Lambertian) are the same.
bool same_material(vec4 a, float ra, vec4 b, float rb) {
    vec4 d = abs(a - b);
    return max(max(d.x, d.y), max(d.z, d.w)) <= MAX_MATERIAL && abs(ra - rb) <= MAX_MATERIAL;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.size))) return;
    vec4 xp = imageLoad(g_position, p);
    if (xp.w == 0.0 || pc.has_history == 0u) {
        imageStore(reprojected, p, vec4(0.0));
        return;
    }
    vec3 x = xp.xyz;
    vec4 nr = unpack_gbuffer_normal(imageLoad(g_normal, p));
    vec3 n = nr.xyz;
    vec4 albedo = unpack_gbuffer_albedo(imageLoad(g_albedo, p));
    vec4 clip = pc.previous_view_proj * vec4(x, 1.0);
    vec4 result = vec4(0.0);
    if (clip.w > 0.0) {
        // Continuous pixel coordinates (pixel centres at i + 0.5).
        vec2 t = (clip.xy / clip.w * 0.5 + 0.5) * vec2(pc.size) - 0.5;
        ivec2 t0 = ivec2(floor(t));
        vec2 f = t - vec2(t0);
        float tolerance = MAX_PLANE * length(x - pc.camera_position.xyz);
        float total = 0.0;
        vec4 sum = vec4(0.0);
        for (int k = 0; k < 4; k++) {
            ivec2 q = t0 + ivec2(k & 1, k >> 1);
            float w = ((k & 1) == 1 ? f.x : 1.0 - f.x) * ((k >> 1) == 1 ? f.y : 1.0 - f.y);
            if (w <= 0.0 || any(lessThan(q, ivec2(0))) || any(greaterThanEqual(uvec2(q), pc.size))) {
                continue;
            }
            vec4 y = imageLoad(previous_position, q);
            vec4 h = imageLoad(previous_history, q);
            vec4 m = unpack_gbuffer_normal(imageLoad(previous_normal, q));
            bool same = y.w != 0.0 && h.a > 0.0
                && dot(m.xyz, n) >= MIN_NORMAL_COS
                && abs(dot(n, y.xyz - x)) <= tolerance
                && same_material(unpack_gbuffer_albedo(imageLoad(previous_albedo, q)), m.w, albedo, nr.w);
            if (same) {
                sum += w * h;
                total += w;
            }
        }
        // Most of the footprint must be the same surface (a sliver of it
        // would extrapolate one history pixel over a disoccluded one).
        if (total >= 0.25) {
            result = sum / total;
            Brdf b = brdf_from_gbuffer(albedo, nr);
            bool moved = any(notEqual(pc.camera_position.xyz, pc.previous_camera.xyz));
            if (moved && !brdf_is_lambertian(b)) {
                // The angle the view direction turned, against the lobe's
                // width (alpha, in radians): the frames kept fall to none
                // at one width.
                vec3 now = normalize(pc.camera_position.xyz - x);
                vec3 before = normalize(pc.previous_camera.xyz - x);
                float turned = length(cross(now, before));
                float keep = clamp(1.0 - turned / max(brdf_alpha(b), 1e-3), 0.0, 1.0);
                result.a *= keep;
                if (result.a <= 0.0) result = vec4(0.0);
            }
        }
    }
    imageStore(reprojected, p, result);
}
