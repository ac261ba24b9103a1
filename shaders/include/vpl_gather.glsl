// The bounded VPL sum at one receiver, shared by the gathers: sum over VPLs
// [first, last) of f_x f_z Phi_i min(G, b) V_ISM, T_b L^. The including
// shader declares `vpl_texels` (the GpuVpls as RGBA32F texels: lavapipe
// fetches a texel in one vector gather, a struct from a storage buffer a
// component and a lane at a time), `ism` (the atlas, r32f) and push
// constants `pc` with tile, far, bound, ism_bias and point_radius.
#ifndef SSBC_VPL_GATHER_GLSL
#define SSBC_VPL_GATHER_GLSL

#include "brdf.glsl"
#include "geometric_normal.glsl"

// ISM test for a receiver x (geometric normal ng) at distance `dist` along
// unit `w` from the VPL at z (normal n). Within the relative tolerance
// alone it is visible. Beyond it, the slope term (ism_tolerance) covers the
// receiver's own surface across the texel, stored along the texel's centre
// ray; but it also let through a wall that faces the VPL at a slant from
// the floor behind it, up to several footprints behind (two rooms sharing
// a thin wall). So where the texel knows the normal of the surface it
// stores and that surface turns across the receiver's (|cos| under
// ISM_PLANE_MAX_COS: it cannot be the receiver's own), its plane is
// followed from the centre ray to the receiver's ray instead, and the
// receiver passes within ISM_PLANE_RELATIVE of the relative tolerance:
// what the plane's quantised normal needs over the texel, not room for a
// curve (half a footprint more let the floor of the next room through a
// 1 mm wall: docs/accuracy.md, "The stored plane's own tolerance").
// (Followed everywhere, the plane shadowed curved surfaces
// from themselves: docs/accuracy.md, "The ISM test follows the stored
// plane".) Neither tells a receiver from what stands on its own surface
// between the centre ray and it: the texels at the foot of a plinth on a
// floor store the floor behind it, and the floor before it reflects the
// VPLs the plinth hides. With `lifted` (a narrow glossy lobe, which shows
// such a leak as a reflection) the receiver passes only if, lifted off its
// surface by ISM_LIFT footprints, it also passes within the relative
// tolerance: the lifted point's ray meets what stands there, its own
// surface lies beyond it. That also where the receiver passed within the
// relative tolerance alone: its texel may be a hole in the plinth's
// splats, which the lifted point's seldom is too (a metal floor of
// roughness 0.3 reflected 1.89x its exact VPL light in the quarter metre
// before a plinth, 1.50x lifted by half a footprint, 1.32x by 0.75, and
// 1.20x by one, which lifts receivers farther out over the plinth's
// shadow: 1.41x in the third band). Lambertian receivers blur such leaks,
// and lifting them cost more in false shadows than it saved
// (docs/accuracy.md, "The lifted ISM test"). Mirrored in
// renderer/readback.rs.
const float ISM_LIFT = 0.75;
const float ISM_PLANE_RELATIVE = 0.5;
const float ISM_PLANE_MAX_COS = 0.3;
// Below this |cos| between the receiver's ray and the stored plane, the
// plane is not followed (its distance along the ray is ill-conditioned).
const float ISM_PLANE_MIN_COS = 0.05;

float ism_lifted_visible(uint cell, vec3 z, vec3 n, vec3 x, vec3 ng, float footprint, float bias) {
    vec3 up = x + ng * (ISM_LIFT * footprint) - z;
    float up_dist = length(up);
    vec3 up_w = up / up_dist;
    // (Lifted behind the VPL's plane: no texel holds it, nothing stands there.)
    if (dot(up_w, n) <= 0.0) return 1.0;
    uint up_stored = imageLoad(ism, ism_texel(cell, ism_map(up_w, n), pc.tile)).r;
    return up_dist <= ism_texel_depth(up_stored) * pc.far + bias * up_dist + ism_floor(pc.far) ? 1.0 : 0.0;
}

float ism_front_visible(uint stored, uint cell, vec2 uv, vec3 z, vec3 n, vec3 x, vec3 ng, vec3 w, float dist, float bias, bool lifted) {
    float depth = ism_texel_depth(stored) * pc.far;
    float relative = bias * dist + ism_floor(pc.far);
    float footprint = ism_footprint(dist, pc.tile, pc.point_radius);
    if (dist <= depth + relative) {
        if (!lifted) return 1.0;
        return ism_lifted_visible(cell, z, n, x, ng, footprint, bias);
    }
    float cos_x = -dot(ng, w);
    // Beyond the slope term at the receiver's own slope, its bound: hidden
    // (most occluded pairs end here, before the stored normal is decoded).
    if (dist > depth + relative + footprint * ism_slope(cos_x)) return 0.0;
    vec3 m;
    bool has_normal = ism_texel_normal(stored, m);
    bool followed = false;
    bool within = false;
    if (has_normal && abs(dot(m, ng)) < ISM_PLANE_MAX_COS) {
        vec3 t, b;
        orthonormal_basis(n, t, b);
        ivec2 local = clamp(ivec2(uv * float(pc.tile)), ivec2(0), ivec2(int(pc.tile) - 1));
        float cm = dot(ism_centre_ray(local, pc.tile, t, b, n), m);
        float wm = dot(w, m);
        followed = abs(wm) > ISM_PLANE_MIN_COS && cm * wm > 0.0;
        within = dist <= depth * cm / wm + ISM_PLANE_RELATIVE * relative;
    }
    if (!followed) {
        float facing = has_normal ? abs(dot(m, w)) : ism_texel_facing(stored);
        within = dist <= depth + ism_tolerance(dist, cos_x, facing, pc.tile, pc.point_radius, bias, pc.far);
    }
    if (!within) return 0.0;
    if (!lifted) return 1.0;
    return ism_lifted_visible(cell, z, n, x, ng, footprint, bias);
}

#ifdef ISM_BACK_FACES
// Whether the back-face map (ism_back_texel) holds a surface seen from
// behind that the receiver's ray leaves before reaching it. Its plane is
// followed from the texel's centre ray to the receiver's; a plane the ray
// grazes (|cos| under ISM_BACK_MIN_COS: the silhouette of a solid) is not.
// The tolerance is the stored normal's quantisation (about a degree) over
// the texel, and float rounding: a receiver never lies on a back face, so
// it needs no room for its own surface's slope or curve.
const float ISM_BACK_MIN_COS = 0.2;
const float ISM_BACK_RELATIVE = 0.002;

bool ism_behind_back_face(ivec2 texel, vec2 uv, vec3 n, vec3 w, float dist) {
    uint back = imageLoad(ism, ism_back_texel(texel, imageSize(ism).y)).r;
    float depth = ism_texel_depth(back) * pc.far;
    // (Most pairs end here: nothing seen from behind before the receiver.)
    if (dist <= depth) return false;
    vec3 m;
    if (!ism_texel_normal(back, m)) return false;
    float wm = dot(w, m);
    if (abs(wm) < ISM_BACK_MIN_COS) return false;
    vec3 t, b;
    orthonormal_basis(n, t, b);
    ivec2 local = clamp(ivec2(uv * float(pc.tile)), ivec2(0), ivec2(int(pc.tile) - 1));
    float cm = dot(ism_centre_ray(local, pc.tile, t, b, n), m);
    if (cm * wm <= 0.0) return false;
    return dist > depth * cm / wm + ISM_BACK_RELATIVE * dist / abs(wm) + ism_floor(pc.far);
}
#endif

float ism_visible(uint cell, vec3 z, vec3 n, vec3 x, vec3 ng, vec3 w, float dist, float bias, bool lifted) {
    vec2 uv = ism_map(w, n);
    ivec2 texel = ism_texel(cell, uv, pc.tile);
    uint stored = imageLoad(ism, texel).r;
    if (ism_front_visible(stored, cell, uv, z, n, x, ng, w, dist, bias, lifted) == 0.0) return 0.0;
#ifdef ISM_BACK_FACES
    // (In builds of their own: the test alone, its flag never set, cost
    // the gathers 2-4% at 1024x768.)
    if ((stored & ISM_BACK_FLAG) != 0u && ism_behind_back_face(texel, uv, n, w, dist)) return 0.0;
#endif
    return 1.0;
}

#ifdef EXACT_VISIBILITY
#include "exact_visibility.glsl"
#endif

// What VPLs first, first + stride, ... (below last) send to a receiver at x
// (shading normal n on a surface of geometric normal ng, BRDF bx, seen from
// wo): its radiance is brdf_diffuse_color(bx) / pi * irradiance + glossy.
// irradiance = sum f_z(incident, z->x) Phi min(G, b) V_ISM (its diffuse,
// view-independent part), glossy = what the rest of f_x adds (0 on a
// Lambertian receiver, which never evaluates its BRDF).
// spread2 = the mean widening spread2 of the glossy lobe, weighted by the
// glossy light (brightness) each VPL sends (0 without any).
struct VplLight {
    vec3 irradiance;
    vec3 glossy;
    float spread2;
};

VplLight vpl_sum(vec3 x, vec3 n, vec3 ng, Brdf bx, vec3 wo, uint first, uint last, uint stride) {
    bool lambertian = brdf_is_lambertian(bx);
    vec3 diffuse = brdf_diffuse_color(bx) / PI;
    // The ISM test's relative tolerance, less for a narrow glossy lobe,
    // which shows a leak as a reflection, and which (alpha under 0.25) also
    // takes the lifted test (twin: indirect_bounded::ism_test_for).
    float bias = lambertian ? pc.ism_bias : pc.ism_bias * clamp(4.0 * brdf_alpha(bx), 0.25, 1.0);
    bool lifted = !lambertian && brdf_alpha(bx) < 0.25;
    VplLight light = VplLight(vec3(0.0), vec3(0.0), 0.0);
    float spread_weight = 0.0;
    for (uint i = first; i < last; i += stride) {
        int at = int(VPL_TEXELS * i);
        vec3 z = texelFetch(vpl_texels, at).xyz;
        vec3 d = x - z;
        float d2 = dot(d, d);
        if (d2 < 1e-10) continue;
        float dist = sqrt(d2);
        vec3 w = d / dist;
        vec4 n_z = texelFetch(vpl_texels, at + 1);
        float cos_z = dot(n_z.xyz, w);
        float cos_x = -dot(n, w);
        if (cos_z <= 0.0 || cos_x <= 0.0) continue;
        float g = min(cos_x * cos_z / d2, pc.bound);
#ifdef EXACT_VISIBILITY
        // The VPL leaves its surface along its normal (it lies on it).
        float v = segment_free(z, n_z.xyz, x, ng, pc.camera_position.w) ? 1.0 : 0.0;
#else
        float v = ism_visible(floatBitsToUint(n_z.w), z, n_z.xyz, x, ng, w, dist, bias, lifted);
#endif
        // Hidden from the VPL: neither BRDF is needed.
        if (v == 0.0) continue;
        vec4 power = texelFetch(vpl_texels, at + 2);
        bool glossy_vpl = power.w >= 0.0;
        // A Lambertian VPL whose shading normal (incident.xyz) turns from
        // its normal sends nothing where that faces away.
        bool shaded_vpl = power.w < -1.5;
        // Glossy lobes towards and from the VPL widen by the angle its
        // radius subtends (a virtual spherical light): a narrow lobe then
        // cannot make one VPL a spike.
        float spread2 = 0.0;
        vec4 incident = vec4(0.0);
        if (glossy_vpl || !lambertian || shaded_vpl) {
            incident = texelFetch(vpl_texels, at + 4);
            spread2 = incident.w * incident.w / d2;
        }
        vec3 sent;
        if (!glossy_vpl) {
            // Lambertian: albedo Phi / pi every way (its shading normal's).
            sent = shaded_vpl && dot(incident.xyz, w) <= 0.0 ? vec3(0.0) : power.rgb / PI;
        } else {
            vec4 base = texelFetch(vpl_texels, at + 3);
            Brdf bz = Brdf(base.rgb, power.w, base.w, 1.0);
            sent = brdf_eval_alpha(bz, brdf_widened_alpha(bz, spread2), n_z.xyz, incident.xyz, w) * power.rgb;
        }
        sent *= g * v;
        light.irradiance += sent;
        if (!lambertian) {
            float diffuse_weight;
            vec3 specular;
            brdf_parts_alpha(bx, brdf_widened_alpha(bx, spread2), n, wo, -w, diffuse_weight, specular);
            light.glossy += (diffuse * (diffuse_weight - 1.0) + specular) * sent;
            float weight = dot(specular * sent, vec3(1.0));
            light.spread2 += weight * spread2;
            spread_weight += weight;
        }
    }
    light.spread2 = spread_weight > 0.0 ? light.spread2 / spread_weight : 0.0;
    return light;
}

#endif
