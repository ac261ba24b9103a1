// Screen-space bias compensation: the residual integral I(x) over both
// layers' pyramids, by brute force or hierarchically (ssbc_walk.glsl).
// Needs the pyramids' reads (ssbc_pyramid_read.glsl) and a push block `pc`
// with `SsbcFrame frame` and `ResidualParams residual`.

#ifndef SSBC_RESIDUAL_GLSL
#define SSBC_RESIDUAL_GLSL


// The residual integral, kept linear in the receiver's normal: over the y
// where G(x, y) > b,
//   I_c(x) = sum max(G - b, 0) A_y S_c(y) = n_x . V_c - b C_c,
//   V_c = sum (w cos(theta_y) / d^2) A_y S_c(y),  C_c = sum A_y S_c(y)
// (w = (y - x) / d). Per colour channel c: xyz V_c, w C_c. A pixel whose
// normal differs a little from an evaluation point's gets n . V - b C, right
// to first order (the set where G > b moves only where G - b is near 0).

// A glossy receiver (a glossy evaluation point, or a glossy pixel evaluated
// alone) also sums what the rest of its BRDF adds, per cluster at
// direction w with excess max(G - b, 0):
//   glossy_rest = sum (f_x(wo, w) - diffuse / pi) max(G - b, 0) A_y S(y),
// so that its S_k = diffuse / pi I(x) + glossy_rest. Set by begin_glossy
// (glossy points and the glossy fallback) before residual_integral;
// inactive elsewhere.
bool glossy_active = false;
BrdfView glossy_view;
vec3 glossy_diffuse;  // its diffuse lobe, brdf_diffuse_color / pi
vec3 glossy_rest = vec3(0.0);
// Its lobe: the mirror direction of wo and GGX alpha. A cluster is refined
// where the BRDF changes across it, not only where G does (see visit()).
vec3 glossy_mirror = vec3(0.0);
float glossy_alpha = 1.0;
// A pixel's area at the receiver's distance from the eye, facing it
// (pixel_area without its cosine of view): source pixels that widen the
// lobe (add_glossy) are near the receiver when they do.
float glossy_pixel_area = 0.0;

// Makes the walks that follow sum the glossy rest of a receiver at x (unit
// normal nx, BRDF b) seen from the eye.
void begin_glossy(Brdf b, vec3 x, vec3 nx) {
    glossy_active = true;
    vec3 wo = normalize(pc.frame.camera_position.xyz - x);
    glossy_view = brdf_view(b, nx, wo);
    glossy_diffuse = brdf_diffuse_color(b) / PI;
    glossy_mirror = reflect(-wo, nx);
    glossy_alpha = brdf_alpha(b);
    glossy_pixel_area = pixel_area(x, wo);
}

// The solid angle of a source pixel (cos(theta_y) / d^2 = k, `pixel_scale`
// image pixels) for add_glossy: its area taken as a pixel's at the
// receiver's distance, facing the eye (glossy_pixel_area; one seen
// obliquely is larger): two products per pixel a glossy walk adds.
float glossy_pixel_omega(float k, float pixel_scale) {
    return k * pixel_scale * glossy_pixel_area;
}

// The squared chord from the mirror direction to unit w.
float mirror_chord2(vec3 w) {
    vec3 off = w - glossy_mirror;
    return dot(off, off);
}

// Adds to glossy_rest what a cluster towards unit w (mirror_chord2(w) =
// chord2) sends with weighted = max(G - b, 0) A_y S(y). A pixel seen over
// a solid angle omega (glossy_pixel_omega) wider than the lobe around its
// peak takes the lobe widened to its angular radius r (r^2 = omega / pi):
// alpha^2 becomes max(alpha^2, r^2), as the gather widens it by a VPL's
// radius (a virtual spherical light), about the mean of the BRDF over the pixel rather than
// its value at the centre, which a pixel beside a contact (omega near
// 1 sr) turned into the lobe's peak times its whole solid angle (a glossy
// floor's row along a wall 5x too bright). Fully where the chord to the
// mirror direction is within r, fading (linearly in the chord squared) to
// nothing at 2 r: in the tail a widened lobe is brighter than the mean of
// the narrow one (alpha^2 / theta^4 grows with alpha^2). Coarser clusters
// keep the lobe: they are refined until they are small against it (see
// visit()). One evaluation, its alpha^2 selected: lavapipe runs both sides
// of an if for the whole SIMD group, and a branch between the widened and
// the plain lobe cost two (measured: docs/accuracy.md, "Tuned constants").
// ssbc::cpu::ssbc::glossy_pixel_spread is the CPU twin's.
void add_glossy(vec3 w, float chord2, vec3 weighted, float omega) {
    if (!glossy_active) return;
    float diffuse_weight;
    vec3 specular;
    float r2 = omega * (1.0 / PI);
    float wider = r2 - glossy_alpha * glossy_alpha;
    float near = clamp((4.0 * r2 - chord2) / (3.0 * r2), 0.0, 1.0);
    float spread2 = wider > 0.0 && chord2 < 4.0 * r2 ? near * wider : 0.0;
    brdf_view_parts(glossy_view, widened_a2(glossy_alpha, spread2), w, diffuse_weight, specular);
    glossy_rest += (glossy_diffuse * (diffuse_weight - 1.0) + specular) * weighted;
}

// Adds y (at d = y - x, normal ny, sum of A_y S(y) `as`; a pixel of
// `pixel_scale` image pixels) if G > b there. `ny` may be shorter than 1 (a
// mean of spread normals): cos(theta_y) is then the area-weighted mean of
// the cosines. Returns what it added per unit of A_y S(y), max(G - b, 0).
float accumulate(inout Residual acc, vec3 nx, vec3 ny, vec3 d, float dist, float pixel_scale, vec3 as) {
    vec3 w = d / dist;
    float cos_x = dot(nx, w);
    float k = max(-dot(ny, w), 0.0) / (dist * dist);
    if (!(cos_x * k > pc.frame.bound)) return 0.0;
    vec3 wk = w * k;
    acc.r += vec4(wk * as.r, as.r);
    acc.g += vec4(wk * as.g, as.g);
    acc.b += vec4(wk * as.b, as.b);
    float excess = cos_x * k - pc.frame.bound;
    add_glossy(w, mirror_chord2(w), excess * as, glossy_pixel_omega(k, pixel_scale));
    return excess;
}

// What a contribution c at distance 1 / inv_d adds to the sums (sum c,
// sum c / d) whose ratio is the variation scale (see residual_integral).
void add_to_scale(inout vec2 scale, float c, float inv_d) {
    scale += vec2(c, c * inv_d);
}

// Adds cluster c of level-0 texel i (a pixel's own surface, or its part
// beyond a crease; `pixel_scale` image pixels a pixel of its layer) if
// G > b there (brute force).
void add_pixel_cluster(inout Residual acc, uint i, uint c, vec3 x, vec3 nx, float r_world, float pixel_scale,
                       inout vec2 scale) {
    GeoCluster g = geo_cluster(i, c);
    vec3 d = g.position_extent.xyz - x;
    float d2 = dot(d, d);
    if (cluster_extent(g).y >= 0.0 && d2 < r_world * r_world && d2 >= 1e-12) {
        vec3 as = cluster_radiance(i, c);
        float dist = sqrt(d2);
        float excess = accumulate(acc, nx, g.normal_cone.xyz, d, dist, pixel_scale, as);
        add_to_scale(scale, excess * (as.r + as.g + as.b), 1.0 / dist);
    }
}

// Whether the residual integral is the brute-force reference
// (`Integration::Brute`) instead of the walk: a specialization constant
// (its own pipelines, `SsbcPass`), so that the walk's kernels carry none of
// the brute force's unrolled rows. With them, Mesa 22.3's LLVM 15 compiled
// the fallback kernels for 810 s from an empty cache; without, 4 s
// (docs/development.md, "Shader compile time on Mesa 22.3").
layout(constant_id = 0) const bool BRUTE_FORCE = false;

// The brute-force loop takes BRUTE_SPAN pixels of a row per iteration,
// unrolled: one per iteration ran into lavapipe's loop limit (CUT_SHORT)
// from a radius of about 128 pixels, 90 with two layers; 16 fit a 1024x768
// window of one layer, or of two with a radius up to about 500 pixels
// (measured: docs/accuracy.md, "Tuned constants").
const int BRUTE_SPAN = 16;

// Every texel of level 0 of pyramid p in the window (the reference);
// `center` and `radius_px` in that pyramid's pixels.
void integrate_brute(inout Residual acc, Pyramid p, vec3 x, vec3 nx, vec2 center, float radius_px, float r_world,
                     inout uint count, inout vec2 scale) {
    float pixel_scale = float(1 << (2 * p.shift));
    ivec2 lo = max(ivec2(floor(center - radius_px)), ivec2(0));
    ivec2 hi = min(ivec2(ceil(center + radius_px)), ivec2(image_size_at(uint(p.shift))) - 1);
    // Row segments in rows (stepped, one loop: see the walk).
    ivec2 q = lo;
    bool more = all(lessThanEqual(lo, hi));
    uint start = count;
    uint window = more ? uint((hi.x - lo.x + 1) * (hi.y - lo.y + 1)) : 0u;
    while (more) {
        [[unroll]] for (int k = 0; k < BRUTE_SPAN; k++) {
            if (q.x + k <= hi.x) {
                count++;
                uint i = texel_index_in(p, ivec2(q.x + k, q.y), 0);
                add_pixel_cluster(acc, i, 0u, x, nx, r_world, pixel_scale, scale);
                add_pixel_cluster(acc, i, 1u, x, nx, r_world, pixel_scale, scale);
            }
        }
        q = q.x + BRUTE_SPAN <= hi.x ? ivec2(q.x + BRUTE_SPAN, q.y) : ivec2(lo.x, q.y + 1);
        more = q.y <= hi.y;
    }
    if (count - start != window) count |= CUT_SHORT;
}

#include "ssbc_walk.glsl"

// The residual integral (see Residual) for a receiver at x with unit normal
// nx seen at pixel coordinates `center`; the residual is albedo(x) / pi *
// I(x). `count` is incremented for every texel read. `variation` becomes the
// length over which I changes: I / |grad I|, with every contribution c
// falling off as 1/d^2 (|grad c| ~ 2c/d), is about the contribution-weighted
// harmonic mean of the distances, sum c / sum(c / d). Near a contact it is
// short (the nearest surface gives most of I); on a concave surface whose
// nearby pixels add little it is not (the distance to the nearest
// contributor was: tori's inner rings were evaluated pixel by pixel).
Residual residual_integral(vec3 x, vec3 nx, vec2 center, inout uint count, out float variation) {
    Residual acc = Residual(vec4(0.0), vec4(0.0), vec4(0.0));
    // G <= 1/d^2, so only |x - y| < 1/sqrt(b) can exceed b.
    float r_world = inversesqrt(pc.frame.bound);
    variation = r_world;
    if (!(r_world > 0.0)) return acc;
    float radius_px = screen_radius(x, r_world);
    vec2 scale = vec2(0.0);
    // Every layer's surfaces are sources (the separation between layers
    // keeps one surface from being counted twice); at half resolution
    // layer 1's window is half as many pixels across.
    if (BRUTE_FORCE) {
        for (uint layer = 0u; layer < layer_count(); layer++) {
            Pyramid p = pyramid_of(layer);
            float to_layer = 1.0 / float(1 << p.shift);
            vec2 c = (center + 0.5) * to_layer - 0.5;
            integrate_brute(acc, p, x, nx, c, radius_px * to_layer, r_world, count, scale);
        }
    } else {
        integrate_hierarchical(acc, x, nx, center, radius_px, r_world, count, scale);
    }
    if (scale.x > 0.0) variation = min(scale.x / scale.y, r_world);
    return acc;
}

#endif
