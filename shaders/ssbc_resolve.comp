#version 460
// SSBC resolve at level pc.level: a pixel interpolates the residual's linear
// form bilinearly from the four evaluation points of that level around it,
// and evaluates it for its own normal, when every point (with a non-zero
// weight) was usable and lies on the pixel's own smooth surface (below) and
// close enough: within 1.5 / texels_per_radius of the bounding radius, and
// within scale_fraction of the point's variation scale (the length over
// which I(x) changes: short near corners and contacts; see
// residual_integral). Otherwise the pixel asks for the four points around it
// one level finer and goes on the pending list for that level; at level 1
// the pending list is the fallback list (the pixel is evaluated alone). At
// level 0 (no level is coarse enough for points) every pixel goes there.
// pc.from_list = 0: every pixel (the coarsest level); 1: the pending list.
#include "ssbc_types.glsl"

layout(push_constant) uniform ResolvePush {
    SsbcFrame frame;
    uint level;               // the level whose points are interpolated
    uint from_list;           // 1: the pixels of `pending_in`; 0: every pixel
    uint generation;          // the step's stamp on its points
    float texels_per_radius;  // evaluation texels wanted across the bounding radius 1/sqrt(b)
    float scale_fraction;     // interpolate over at most this x a point's variation scale
} pc;

#include "ssbc_pyramid.glsl"
#include "ssbc_pyramid_read.glsl"
#include "ssbc_output.glsl"

// Per evaluation point, the generation of the step that last asked for it
// (each point is requested once per step).
layout(set = 0, binding = 3) buffer Claims { uint claims[]; };
// Per evaluation point, at glossy receivers, the glossy rest and the
// generation of the step that computed it (pack_point_rest; see EvalPoint).
layout(set = 0, binding = 16) uniform utextureBuffer point_glossy;

layout(local_size_x = 64) in;

// Same smooth surface: normals within ~37 degrees (the residual is carried
// linear in the normal, see Residual), and the point within 0.25 x its
// distance of the pixel's tangent plane.
const float MIN_NORMAL_COS = 0.8;
const float MAX_PLANE = 0.25;

// How far (chord of the mirror directions, / GGX alpha) a glossy pixel's
// lobe may point from an evaluation point's for the point's glossy rest to
// stand for the pixel's. See docs/ssbc-implementation.md.
const float GLOSSY_POINT_TURN = 0.35;
// How much the material may differ (base colour, metallic, roughness).
const float GLOSSY_POINT_MATERIAL = 0.02;
// How far (summed over the channels) the points' glossy rests may differ
// from their blend, on average with their bilinear weights, against the
// pixel's whole residual, for points whose lobes point apart (see
// same_lobe) to stand for it: the light they reflect hardly changes
// across their lobes, so neither across the pixel's, which lies among
// theirs on a smooth surface. The weighted mean rather than the largest
// deviation: a pixel on a point takes its rest, whatever its neighbours
// say (measured: docs/accuracy.md, "Tuned constants").
const float AGREE = 0.02;

// Whether an evaluation point with a glossy rest (at pixel q) computed it
// for the material of a glossy pixel (base colour and roughness
// `material`, BRDF b).
bool same_material(ivec2 q, vec4 material, Brdf b) {
    vec4 albedo = unpack_gbuffer_albedo(imageLoad(g_albedo, q));
    vec4 other = vec4(albedo.rgb, unpack_gbuffer_normal(imageLoad(g_normal, q)).w);
    vec4 diff = abs(other - material);
    float metal = abs(albedo.w - b.metallic);
    return max(max(diff.x, diff.y), max(max(diff.z, diff.w), metal)) <= GLOSSY_POINT_MATERIAL;
}

// Whether the lobe of an evaluation point (position y, normal n) points
// within GLOSSY_POINT_TURN x alpha of the pixel's mirror direction.
bool same_lobe(vec3 y, vec3 n, vec3 mirror, Brdf b) {
    vec3 other_mirror = reflect(normalize(y - pc.frame.camera_position.xyz), n);
    return length(other_mirror - mirror) <= GLOSSY_POINT_TURN * brdf_alpha(b);
}

// Bilinear footprint of pixel p among the evaluation points of level l.
void footprint(ivec2 p, int l, out ivec2 t0, out vec2 fraction) {
    vec2 f = (vec2(p) - float((1 << l) >> 1)) / float(1 << l);
    t0 = ivec2(floor(f));
    fraction = f - vec2(t0);
}

float corner_weight(vec2 fraction, int k) {
    return ((k & 1) == 1 ? fraction.x : 1.0 - fraction.x) * ((k >> 1) == 1 ? fraction.y : 1.0 - fraction.y);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    ivec2 p;
    if (pc.from_list == 1u) {
        if (i >= pending_in.header.count) return;
        p = unpack_item(pending_in.items[i]);
    } else {
        // One row of work groups per image row (no integer division).
        p = ivec2(gl_GlobalInvocationID.xy);
        if (p.x >= int(pc.frame.size.x)) return;
    }
    vec4 xp = imageLoad(g_position, p);
    if (xp.w == 0.0) {
        if (keeps_residual()) imageStore(residual, p, vec4(0.0));
        if (keeps_sources()) imageStore(residual_sources, p, vec4(0.0));
        imageStore(final_image, p, imageLoad(previous, p));
        imageStore(samples, p, vec4(-1.0)); // no geometry (read back as 0)
        return;
    }
    vec3 x = xp.xyz;
    vec3 nx = unpack_gbuffer_normal(imageLoad(g_normal, p)).xyz;
    Brdf b = pixel_brdf(p);
    // A glossy receiver's BRDF depends on each source's direction, which an
    // evaluation point's linear form does not keep. If its BRDF hardly
    // depends on it (nearly_lambertian) it takes the linear form; otherwise
    // it takes the glossy rest the points computed for their own pixels'
    // BRDFs, where those are its material and their lobes point nearly
    // where its own does (same_lobe) or their glossy rests agree (AGREE).
    vec3 wo = normalize(pc.frame.camera_position.xyz - x);
    bool lambertian = brdf_is_lambertian(b);
    // (The geometry pass marked the pixel if it is not nearly Lambertian.)
    bool glossy = (geo_aux(texel_index(0u, p, 0)).flags & GLOSSY_RECEIVER) != 0u;
    vec3 mirror = reflect(-wo, nx);
    vec4 material = vec4(unpack_gbuffer_albedo(imageLoad(g_albedo, p)).rgb, b.roughness);
    vec3 rest_blend = vec3(0.0);
    int l = int(pc.level);
    if (l == 0) {
        // There are no points at level 0 (point_index): the pixel is
        // evaluated alone.
        APPEND_ITEM_TO(pending_out, pack_item(p), glossy);
        return;
    }
    float t_cam = length(x - pc.frame.camera_position.xyz);
    float r_world = inversesqrt(pc.frame.bound);
    float max_spacing = 1.5 * r_world / pc.texels_per_radius;
    bool ok = screen_radius(x, r_world) >= pc.texels_per_radius * float(1 << l);
    ivec2 t0;
    vec2 fraction;
    footprint(p, l, t0, fraction);
    ivec2 size_l = level_size(0u, l);
    Residual blend = Residual(vec4(0.0), vec4(0.0), vec4(0.0));
    // A glossy pixel: whether every point's lobe is its own, and the
    // points' glossy rests (see AGREE).
    bool lobes = true;
    vec3 rests[4] = vec3[4](vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0));
    for (int k = 0; k < 4 && ok; k++) {
        ivec2 t = t0 + ivec2(k & 1, k >> 1);
        float w = corner_weight(fraction, k);
        if (w > 0.0) {
            ok = all(greaterThanEqual(t, ivec2(0))) && all(lessThan(t, size_l));
            if (ok) {
                EvalPoint point = load_point(point_texels, point_tails, point_index(t, l));
                GeoCluster g = eval_pixel_inside(t, l) ? geo_cluster(texel_index(0u, eval_pixel(t, l), 0), 0u)
                                                       : empty_cluster();
                // The point's surface (geometric) normal: near the pixel's
                // shading normal, and the pixel on its tangent plane.
                // (The point's own shading normal costs one more image
                // load per point and pixel for nothing without normal
                // maps (measured: docs/accuracy.md, "Tuned constants").)
                vec3 n = g.normal_cone.xyz;
                vec3 d = x - g.position_extent.xyz;
                float dist = length(d);
                ok = point.generation == pc.generation && point.reads >= 0.0
                    && dot(nx, n) >= MIN_NORMAL_COS && abs(dot(n, d)) <= MAX_PLANE * dist + 1e-5 * t_cam
                    && dist <= min(max_spacing, pc.scale_fraction * point.variation);
                if (glossy && ok) {
                    uvec2 packed_rest = texelFetch(point_glossy, int(point_index(t, l))).xy;
                    vec3 rest = point_rest(packed_rest);
                    ok = point_rest_generation(packed_rest) == pc.generation && same_material(eval_pixel(t, l), material, b);
                    // The point's lobe: about its shading normal.
                    vec3 n_point = unpack_gbuffer_normal(imageLoad(g_normal, eval_pixel(t, l))).xyz;
                    lobes = lobes && same_lobe(g.position_extent.xyz, n_point, mirror, b);
                    rests[k] = rest;
                    rest_blend += w * rest;
                }
                blend.r += w * point.residual.r;
                blend.g += w * point.residual.g;
                blend.b += w * point.residual.b;
            }
        }
    }
    vec3 integral = residual_at(blend, nx);
    // Whether the points stand for the pixel's Lambertian part but not for
    // its glossy rest.
    bool rest_only = false;
    if (ok && glossy && !lobes) {
        // Lobes that point apart still stand for the pixel where their
        // glossy rests agree (see AGREE).
        vec3 total = brdf_diffuse_color(b) / PI * integral + rest_blend;
        float spread = 0.0;
        for (int k = 0; k < 4; k++) {
            vec3 d = abs(rests[k] - rest_blend);
            spread += corner_weight(fraction, k) * (d.r + d.g + d.b);
        }
        ok = spread <= AGREE * (total.r + total.g + total.b);
        rest_only = !ok;
    }
    if (ok) {
        vec3 rest = lambertian ? vec3(0.0)
            : glossy ? rest_blend : nearly_lambertian_rest(b, nx, wo, blend, integral);
        write_residual(p, b, integral, rest, 0.0);
        return;
    }
    if (l >= 2) {
        // Ask for the points one level finer (each once per step).
        footprint(p, l - 1, t0, fraction);
        for (int k = 0; k < 4; k++) {
            ivec2 t = t0 + ivec2(k & 1, k >> 1);
            if (corner_weight(fraction, k) > 0.0 && all(greaterThanEqual(t, ivec2(0)))
                && all(lessThan(t, level_size(0u, l - 1)))) {
                if (atomicExchange(claims[point_index(t, l - 1)], pc.generation) != pc.generation) {
                    // Points at glossy receivers at the back (ssbc_eval.glsl).
                    uint q_index = texel_index(0u, eval_pixel(t, l - 1), 0);
                    bool glossy_point = eval_pixel_inside(t, l - 1)
                        && (geo_aux(q_index).flags & GLOSSY_RECEIVER) != 0u;
                    APPEND_ITEM_TO(requests, pack_item(t), glossy_point);
                }
            }
        }
    }
    // Glossy receivers at the back of the fallback list (ssbc_fallback.glsl).
    if (l == 1 && rest_only) {
        // The fallback adds its glossy rest (ssbc_fallback.glsl).
        write_residual(p, b, integral, vec3(0.0), 0.0);
    }
    APPEND_ITEM_TO(pending_out, pack_item(p) | (l == 1 && rest_only ? REST_ONLY : 0u), l == 1 && glossy);
}
