// Screen-space bias compensation: the hierarchical walk over the pyramids
// (included by ssbc_residual.glsl, whose helpers it uses).

// Largest cos(theta_y) = n_y . (x - y) / |x - y| over a texel whose normals
// lie in a cone (cosine cone_cos) around the unit mean n, seen from x at
// distance dist (> extent; inv_dist = 1 / dist) in direction -d/dist: the
// angle between n and x - y is at least A - B, A = angle(n, x - mean),
// B = cone + asin(extent / dist).
float max_cos_y(vec3 n, float cone_cos, vec3 d, float inv_dist, float extent) {
    float sigma = extent * inv_dist;
    if (!(sigma < 1.0)) return 1.0;
    float cos_s = sqrt(1.0 - sigma * sigma);
    float sin_c = sqrt(max(1.0 - cone_cos * cone_cos, 0.0));
    float cos_b = cone_cos * cos_s - sin_c * sigma;
    if (cos_b <= 0.0) return 1.0;                     // B >= 90 degrees: no bound
    float sin_b = sin_c * cos_s + cone_cos * sigma;
    float cos_a = clamp(-dot(n, d) * inv_dist, -1.0, 1.0);
    if (cos_a >= cos_b) return 1.0;                   // A <= B
    return cos_a * cos_b + sqrt(1.0 - cos_a * cos_a) * sin_b;  // cos(A - B)
}

// What to do with one cluster (empty clusters are skipped):
const int SKIP = 0;
const int ADD = 1;
const int REFINE = 2;

// One cluster as the traversal sees it: what to do with it, and what adding
// it from its means adds per unit of A_y S(y) in the linear form of
// `Residual` (see `accumulate` and SPREAD): wk to V, weight to C.
struct Visit {
    int action;
    vec3 wk;          // weight x w cos(theta_y) / d^2 at the mean (+ the straddling term)
    float weight;     // 0: adds nothing
    float inv_dist;   // 1 / distance to its mean
    vec3 w;           // unit direction to its mean (a glossy receiver's BRDF)
    float k;          // cos(theta_y) / d^2 at its mean (a pixel's solid angle: glossy_pixel_omega)
    float chord2;     // mirror_chord2(w) at a glossy receiver
};

// Adding a cluster from its mean takes max(G - b, 0) at the mean for the
// mean of max(G - b, 0) over its pixels: always too little (max is convex),
// by up to half of how much G varies over the cluster where G ~ b there.
// G = cos_x cos_y / d^2 changes by about
//   s = SPREAD (R / d) (2 G + (cos_x + cos_y) / d^2)
// across a cluster of bounding radius R (first order in R / d). Taking G
// spread evenly over [G - s, G + s], the mean of max(G - b, 0) is, with
// m = G - b and t = (m + s) / 2s in [0, 1]:
//   m (m >= s),  (m + s)^2 / 4s = t/2 (G - b) + t/2 s (|m| < s),  0 (m <= -s).
// SPREAD (the pixels' r.m.s. offset over R, about): the value whose mean
// residual matches brute force (measured: docs/accuracy.md, "Tuned constants").
const float SPREAD = 0.3;
// What a glossy receiver refines: clusters seen wider than glossy_refine
// of its lobe's local angular scale (visit()), or glossy_refine_near of it
// within glossy_near of the lobe's mirror direction. A pixel's own walk
// 0.25 everywhere by default; glossy evaluation points and the glossy
// fallback set their own (ssbc_eval.glsl, ssbc_fallback.glsl)
// (measured: docs/accuracy.md, "Tuned constants").
float glossy_refine = 0.25;
float glossy_refine_near = 0.25;
float glossy_near = 0.0;
// Whether only the glossy rest is wanted (the Lambertian part came from
// evaluation points): the geometric refinement is REST_ONLY_COARSER x
// coarser, as coarse as keeps the error against brute force within the
// tests' limit (measured: docs/accuracy.md, "Tuned constants").
const float REST_ONLY_COARSER = 5.0;
// A glossy walk refines by its lobe only clusters where G may exceed
// (1 + LOBE_EXCESS refine_excess) b (a rest-only walk, whose geometry is
// coarser, everywhere): elsewhere max(G - b, 0) is small and the BRDF's
// change across the cluster changes little (measured: docs/accuracy.md, "Tuned constants").
const float LOBE_EXCESS = 0.25;
bool glossy_rest_only = false;
// A rest-only walk skips the clusters that lie wholly more than
// REST_ONLY_FAR alphas from the lobe's mirror direction. What they drop
// is GGX's tail there and the Fresnel weight's change of the diffuse lobe
// (-0.04 w of it) (measured: docs/accuracy.md, "Tuned constants").
const float REST_ONLY_FAR = 15.0;

// A cluster is skipped if G cannot exceed b anywhere in it: G <= cos_x cos_y
// / d^2 with d >= dist - radius, cos_x bounded by the bounding slab (it
// reaches at most `reach` in front of the receiver's tangent plane) and cos_y
// by the normal cone; a cluster behind the tangent plane or facing away has
// G = 0. It needs refining if its bounding sphere is larger than
// refine_ratio x its distance and G may exceed (1 + refine_excess) b in it
// (where it cannot, max(G - b, 0) <= refine_excess b bounds what it adds,
// error included); otherwise it is added from its means.
// Written without early returns and with one reciprocal square root per
// vector: lavapipe runs every branch of a divergent SIMD group anyway, and
// square roots and divisions are most of a texel's cost there.
Visit visit(GeoCluster g, vec3 x, vec3 nx, float r_world, int level) {
    vec2 extent = cluster_extent_m(g, pc.frame.camera_position.xyz, pc.frame.camera_forward.xyz);  // radius, thickness
    vec3 d = g.position_extent.xyz - x;
    float d2 = dot(d, d);
    float inv_dist = inversesqrt(max(d2, 1e-30));
    float dist = d2 * inv_dist;
    float d_min = dist - extent.x;
    vec3 ny = g.normal_cone.xyz;
    float ny2 = dot(ny, ny);
    vec3 axis = ny2 > 0.0 ? ny * inversesqrt(ny2) : vec3(0.0);
    float a = clamp(dot(nx, axis), -1.0, 1.0);
    float along = dot(nx, d);
    float reach = along + abs(a) * extent.y + sqrt(1.0 - a * a) * extent.x;
    // A coplanar cluster reaches 0 up to rounding of its normals (1e-3 of its extent).
    bool skip = extent.y < 0.0 || d_min >= r_world || reach <= 1e-3 * extent.x;
    bool may_exceed = true;  // G may exceed (1 + refine_excess) b somewhere in it
    bool lobe_matters = true;  // G may exceed (1 + LOBE_EXCESS refine_excess) b in it
    if (d_min > 0.0) {
        // G <= cos_x / d_min^2 = min(d_min, reach) / d_min^3, and the cone's
        // bound on cos_y; compared as G d_min^3 (no division).
        float cube = d_min * d_min * d_min;
        float g_cube = min(d_min, reach);
        g_cube = g_cube <= pc.frame.bound * cube ? g_cube : g_cube * max_cos_y(axis, g.normal_cone.w, d, inv_dist, extent.x);
        skip = skip || g_cube <= pc.frame.bound * cube;
        may_exceed = g_cube > (1.0 + pc.residual.refine_excess) * pc.frame.bound * cube;
        lobe_matters = g_cube > (1.0 + LOBE_EXCESS * pc.residual.refine_excess) * pc.frame.bound * cube;
    }
    // The mean's own geometry term, k = cos(theta_y) / d^2, and the mean of
    // max(G - b, 0) over the cluster (see SPREAD; s = 0 for a pixel).
    float k = max(-dot(ny, d), 0.0) * inv_dist * inv_dist * inv_dist;
    float g_mean = along * inv_dist * k;
    float m = g_mean - pc.frame.bound;
    float s = SPREAD * extent.x * inv_dist * (2.0 * abs(g_mean) + (abs(along) * inv_dist + k * d2) * inv_dist * inv_dist);
    float t = clamp((m + s) / max(2.0 * s, 1e-30), 0.0, 1.0);
    bool straddles = m < s && s > 0.0;
    float weight = dist > 1e-6 ? (straddles ? 0.5 * t : (m > 0.0 ? 1.0 : 0.0)) : 0.0;
    float ratio = pc.residual.refine_ratio * (glossy_rest_only ? REST_ONLY_COARSER : 1.0);
    bool wide = extent.x > ratio * dist && may_exceed;
    // A glossy receiver refines what its BRDF changes across wherever G > b:
    // GGX changes over an angle of about a quarter of (alpha + the angle
    // from the mirror direction), so clusters wider than that, seen from
    // x, are refined (measured: docs/accuracy.md, "Tuned constants").
    float chord2 = glossy_active ? mirror_chord2(d * inv_dist) : 0.0;
    float seen = extent.x * inv_dist;
    // The angle from the chord c to the mirror direction, 2 asin(c / 2)
    // to third order: exact near the mirror, where the test is fine, and
    // at most 26% short at 180 degrees (a little more refined there); acos
    // costs a square root and a polynomial per cluster (measured: docs/accuracy.md, "Tuned constants").
    float off_mirror = sqrt(chord2) * (1.0 + chord2 * (1.0 / 24.0));
    float beyond = max(off_mirror - seen, 0.0);
    skip = skip || (glossy_rest_only && beyond > REST_ONLY_FAR * glossy_alpha);
    if (glossy_active && !skip && !wide && (lobe_matters || glossy_rest_only)) {
        wide = seen > (beyond < glossy_near ? glossy_refine_near : glossy_refine) * (glossy_alpha + beyond);
    }
    int action = skip ? SKIP : (level > 0 && wide ? REFINE : ADD);
    // The straddling term t/2 s is constant: n . n = 1 carries it in V.
    vec3 wk = weight * (d * (inv_dist * k) + (straddles ? s : 0.0) * nx);
    return Visit(action, wk, weight, inv_dist, d * inv_dist, k, chord2);
}

// Adds a visited cluster from its means: the mean of max(G - b, 0) over it
// times sum(A_y S(y)), kept linear in the receiver's normal nx.
// Returns max(G - b, 0) A_y S(y) summed over it (zero if not added): what a
// glossy receiver weights by its BRDF towards v.w (add_glossy_visits).
vec3 add_visit(inout Residual acc, Visit v, vec3 as, vec3 nx, inout vec2 scale) {
    vec3 weighted = vec3(0.0);
    if (v.action == ADD && v.weight > 0.0) {
        acc.r += vec4(v.wk * as.r, v.weight * as.r);
        acc.g += vec4(v.wk * as.g, v.weight * as.g);
        acc.b += vec4(v.wk * as.b, v.weight * as.b);
        float excess = max(dot(nx, v.wk) - pc.frame.bound * v.weight, 0.0);
        weighted = excess * as;
        add_to_scale(scale, excess * (as.r + as.g + as.b), v.inv_dist);
    }
    return weighted;
}

// A glossy receiver's rest for the clusters of a texel that were added
// (`*_weighted` from add_visit): the BRDF in a loop over those, so that a
// SIMD group whose lanes add at most one cluster evaluates it once;
// lavapipe runs both sides of an if for the whole group, so called once
// per cluster it cost two evaluations per texel. A group whose lanes add
// nothing costs little here; what was tried instead is in
// docs/performance.md ("Tuned constants" in docs/accuracy.md).
// At `level` 0 each is a pixel of `pixel_scale` image pixels, whose solid
// angle may widen the lobe (add_glossy).
void add_glossy_visits(int level, float pixel_scale, Visit front, vec3 front_weighted, Visit back,
                       vec3 back_weighted) {
    if (!glossy_active) return;
    bool f = any(greaterThan(front_weighted, vec3(0.0)));
    bool b = any(greaterThan(back_weighted, vec3(0.0)));
    int n = int(f) + int(b);
    for (int c = 0; c < n; c++) {
        bool take_front = f && c == 0;
        float omega = level == 0 ? glossy_pixel_omega(take_front ? front.k : back.k, pixel_scale) : 0.0;
        add_glossy(take_front ? front.w : back.w, take_front ? front.chord2 : back.chord2,
                   take_front ? front_weighted : back_weighted, omega);
    }
}

// Where a walk starts in one layer's pyramid: its roots, the texels of the
// coarsest level that is about half the radius on screen, in the window
// around `center` (image pixels; `radius_px` too).
struct Roots {
    Pyramid p;
    int level;
    ivec2 lo;
    ivec2 hi;
};

Roots roots_of(uint layer, vec2 center, float radius_px) {
    Pyramid p = pyramid_of(layer);
    float to_layer = 1.0 / float(1 << p.shift);
    vec2 c = (center + 0.5) * to_layer - 0.5;
    float r = radius_px * to_layer;
    int level = clamp(int(ceil(log2(max(r, 1.0) * 0.5))), 0, p.levels - 1);
    ivec2 lo = max(ivec2(floor(c - r)) >> level, ivec2(0));
    ivec2 hi = min(ivec2(ceil(c + r)) >> level, level_size_of(p.size, level) - 1);
    // Never empty: c lies in the image (the walk reads at least one root).
    return Roots(p, level, lo, max(hi, lo));
}

uint root_count(Roots w) {
    return uint((w.hi.x - w.lo.x + 1) * (w.hi.y - w.lo.y + 1));
}

// Which children of a refined texel at level z + 1 the walk visits (4 bits
// per level; pyramid_levels in src/passes/ssbc.rs keeps them below 16).
uint children_at(uvec2 children, int z) {
    return ((z < 8 ? children.x : children.y) >> (4 * (z & 7))) & 15u;
}

uvec2 set_children_at(uvec2 children, int z, uint m) {
    uint shift = 4u * uint(z & 7);
    if (z < 8) {
        children.x = (children.x & ~(15u << shift)) | (m << shift);
    } else {
        children.y = (children.y & ~(15u << shift)) | (m << shift);
    }
    return children;
}

// The lowest set bit of a 4-bit mask m != 0, from a table (2 bits per m):
// faster than findLSB on lavapipe (measured: docs/accuracy.md, "Tuned constants").
int lowest_of_4(uint m) {
    return int((0x12131210u >> (2u * m)) & 3u);
}

// The lowest set bit of v != 0 (below 2^24): the exponent of its lowest
// power of two as a float (see lowest_of_4).
int lowest_bit(uint v) {
    return int(floatBitsToUint(float(v & (0u - v))) >> 23) - 127;
}

// Top-down over every layer's pyramid, from its roots, layer after layer in
// one loop: a SIMD group runs as many iterations as its busiest lane needs
// in all, not the sum of each layer's busiest (measured: docs/accuracy.md, "Tuned constants"). Every texel read
// is counted.
// A texel is refined if either of its clusters needs refining; otherwise
// its clusters are added or skipped. A refined texel's children are
// visited unless they only hold members of a cluster that was skipped
// (G <= b over all of it): at a silhouette one cluster is often near x and
// the other beyond the bounding radius or behind x's tangent plane.
// The walk is one flat loop without a stack of texels (and without
// break/continue, which lavapipe's SIMD loops have mishandled): a texel's
// children (up to four; one beyond the last row or column never holds
// members) are visited in the order (0,0) (1,0) (0,1) (1,1) as far as the
// level's bits in `children` say; after a
// texel comes its first child if refined, else its next sibling, climbing
// first to the nearest level whose texel has siblings left (`pending`).
void integrate_hierarchical(inout Residual acc, vec3 x, vec3 nx, vec2 center, float radius_px, float r_world,
                            inout uint count, inout vec2 scale) {
    // Both windows up front: lavapipe runs every branch of the loop body on
    // every iteration, so switching layers there must be cheap.
    Roots w = roots_of(0u, center, radius_px);
    Roots next = layer_count() > 1u ? roots_of(1u, center, radius_px) : w;
    bool last = layer_count() == 1u;
    // Roots finished, against the windows' (see CUT_SHORT).
    uint roots = 0u;
    uint window = root_count(w) + (last ? 0u : root_count(next));
    // Roots in rows, x fastest (stepped, not divided: lavapipe has no vector
    // integer division and would run eight scalar ones per iteration).
    ivec3 t = ivec3(w.lo, w.level);
    uvec2 children = uvec2(0u);
    uint pending = 0u;  // bit z: the texel visited at level z has siblings left
    bool more = true;
    while (more) {
        count++;
        uint i = texel_index_in(w.p, t.xy, t.z);
        GeoTexel texel = geo_texel(i);
        Visit front = visit(texel.front, x, nx, r_world, t.z);
        Visit back = visit(texel.back, x, nx, r_world, t.z);
        uint bits = children_bits(texel.front);
        uint visit_children = (front.action != SKIP ? bits & 15u : 0u) | (back.action != SKIP ? bits >> 4 : 0u);
        bool refine = (front.action == REFINE || back.action == REFINE) && visit_children != 0u;
        if (!refine) {
            vec3 front_radiance, back_radiance;
            texel_radiance(i, front_radiance, back_radiance);
            vec3 front_weighted = add_visit(acc, front, front_radiance, nx, scale);
            vec3 back_weighted = add_visit(acc, back, back_radiance, nx, scale);
            add_glossy_visits(t.z, float(1 << (2 * w.p.shift)), front, front_weighted, back, back_weighted);
        }
        int z = t.z - 1;
        int k = lowest_of_4(visit_children);
        ivec2 first = t.xy * 2 + ivec2(k & 1, k >> 1);
        if (!refine) {
            // The nearest level at or above t's with a sibling left, or the roots'.
            uint above = pending >> t.z;
            int climb = above != 0u ? lowest_bit(above) : w.level - t.z;
            z = t.z + climb;
            ivec2 a = t.xy >> climb;
            visit_children = children_at(children, z);
            k = (a.x & 1) | ((a.y & 1) << 1);
            k += 1 + lowest_of_4(visit_children >> (k + 1));
            first = (a & ~1) + ivec2(k & 1, k >> 1);
            if (z == w.level) {
                roots++;
                first = a.x < w.hi.x ? ivec2(a.x + 1, a.y) : ivec2(w.lo.x, a.y + 1);
                if (first.y > w.hi.y) {
                    // Past the last root: the next layer's, or the end.
                    more = !last;
                    last = true;
                    w = next;
                    first = w.lo;
                    z = w.level;
                }
            }
        } else {
            children = set_children_at(children, z, visit_children);
        }
        // Whether the texel at level z has siblings left after child k.
        bool left = z < w.level && (visit_children >> (k + 1)) != 0u;
        uint bit = z < w.level ? 1u << z : 0u;
        pending = left ? pending | bit : pending & ~bit;
        t = ivec3(first, z);
    }
    if (roots != window) count |= CUT_SHORT;
}

