// Screen-space bias compensation: the pyramids and the residual integral
// shared by every SSBC kernel. Mirrored by src/passes/ssbc.rs (SsbcPush).
//
// The pyramids live in storage buffers, level after level (level l of a
// W x H pyramid is (W >> l) x (H >> l) texels; W and H are padded so every
// level halves exactly, which also gives every texel four children):
//   geo[]       what the traversal reads: each texel's surface as two clusters
//   aux[]       areas, pixels with geometry, continuity, how the children's
//               clusters were grouped (pyramid builds and evaluation points only)
//   radiance[]  sum of A_y S_{k-1}(y) per cluster (rebuilt every step)
// With a second layer (a deep G-buffer's layer 1: the nearest surfaces at
// least a separation behind the visible ones, at full or half resolution),
// its pyramid follows the first in the same buffers; at half resolution
// level l of it covers the screen as level l + 1 of the first does (see
// Pyramid).
//
// A texel's pixels are grouped by depth into a front and a back cluster
// (split at the largest gap in depth between its children's clusters): at a
// silhouette the two are the surfaces on either side of it, each compact,
// so a texel far enough from x for both is added whole instead of being
// refined down to single pixels along every silhouette.
//
// Bindings 0..2 are the same in every kernel that includes this file. The
// kernels that only read the pyramids (#define SSBC_READ_PYRAMIDS first) see
// geo[] and radiance[] as texel buffers: a texel fetch reads 16 bytes in one
// gather where a storage-buffer load costs lavapipe a per-lane loop for every
// 4 bytes (src/vk/buffer_view.rs).

#ifndef SSBC_GLSL
#define SSBC_GLSL

#extension GL_EXT_control_flow_attributes : require

#include "common.glsl"

struct GeoCluster {
    vec4 position_extent;     // xyz area-weighted mean position; w two halves (packHalf2x16,
                              // rounded up): the radius of a sphere around the mean holding
                              // every pixel position of the cluster, and the half-thickness
                              // of a slab along the mean normal holding them (< 0: empty)
    vec4 normal_cone;         // xyz area-weighted mean of the unit normals (shorter than 1
                              // where they spread); w cosine of the half-angle of a cone
                              // around their mean direction holding every one of them
};

struct GeoTexel {
    GeoCluster front;         // levels >= 1: the low 8 bits of normal_cone.z say which
    GeoCluster back;          // children hold members of each cluster (children_bits)
};

// A texel's children (bit k: child k, in the order (0,0) (1,0) (0,1) (1,1))
// that hold members of its front (bits 0..3) and back (bits 4..7) cluster,
// kept in the low 8 mantissa bits of the front cluster's mean normal's z:
// the traversal reads them with the texel, and skips the children that
// only hold members of clusters it skipped. Changing those bits moves the
// normal's direction by less than 2^-15 radians, well within the 1e-3
// radians its cone is widened by for rounding (ssbc_geometry_mips.comp).
// A z of 0 (axis-aligned normals are common) would become a denormal,
// which costs lavapipe's x86 code a microcode assist per operation (one
// layer's SSBC step +23% on tori): it becomes about 2^-60 first (its square
// is still a normal float).
const float SMALLEST_Z = 8.6736174e-19;

GeoCluster with_children_bits(GeoCluster g, uint bits) {
    float z = g.normal_cone.z;
    z = abs(z) < SMALLEST_Z ? (z < 0.0 ? -SMALLEST_Z : SMALLEST_Z) : z;
    g.normal_cone.z = uintBitsToFloat((floatBitsToUint(z) & ~255u) | bits);
    return g;
}

uint children_bits(GeoCluster front) {
    return floatBitsToUint(front.normal_cone.z) & 255u;
}

// (radius, thickness) of a cluster.
vec2 cluster_extent(GeoCluster g) {
    return unpackHalf2x16(floatBitsToUint(g.position_extent.w));
}

GeoCluster make_cluster(vec3 position, float radius, float thickness, vec3 normal, float cone_cos) {
    // Halves keep 11 bits: scale up by 2^-10 (and 1e-7 absolute for
    // subnormals) so that the stored bounds still hold.
    vec2 extent = vec2(radius, thickness);
    if (thickness >= 0.0) extent = extent * (1.0 + 1.0 / 1024.0) + 1e-7;
    return GeoCluster(vec4(position, uintBitsToFloat(packHalf2x16(extent))), vec4(normal, cone_cos));
}

GeoCluster empty_cluster() {
    return make_cluster(vec3(0.0), 0.0, -1.0, vec3(0.0), 1.0);
}

struct GeoAux {
    float front_area;         // summed world-space area A_y of each cluster's pixels
    float back_area;
    uint pixels;              // pixels with geometry under the texel
    uint flags;               // bit 0: one smooth surface (may stand for its pixels);
                              // level 0, bits 1..4: k + 1 if the back cluster is the
                              // part of the pixel on neighbour CREASE_NEIGHBOURS[k]'s surface;
                              // levels >= 1, bit 8 + 2k + c: cluster c of child k went
                              // to the back cluster
};

// The neighbours a pixel's footprint looks at (ssbc_geometry_base.comp).
const ivec2 CREASE_NEIGHBOURS[8] = ivec2[](ivec2(-1, 0), ivec2(1, 0), ivec2(0, -1), ivec2(0, 1),
                                           ivec2(-1, -1), ivec2(1, -1), ivec2(-1, 1), ivec2(1, 1));

#ifdef SSBC_READ_PYRAMIDS
layout(set = 0, binding = 0) uniform usamplerBuffer geo_texels;       // four per GeoTexel
layout(set = 0, binding = 1) readonly buffer Aux { GeoAux aux[]; };
layout(set = 0, binding = 2) uniform samplerBuffer radiance_texels;   // two per texel: front, back

// Cluster c (0 front, 1 back) of texel i.
GeoCluster geo_cluster(uint i, uint c) {
    int at = int(4u * i + 2u * c);
    return GeoCluster(uintBitsToFloat(texelFetch(geo_texels, at)),
                      uintBitsToFloat(texelFetch(geo_texels, at + 1)));
}

// Sum of A_y S(y) over cluster c of texel i.
vec3 cluster_radiance(uint i, uint c) {
    return texelFetch(radiance_texels, int(2u * i + c)).rgb;
}
#else
layout(set = 0, binding = 0) buffer Geo { GeoTexel geo[]; };
layout(set = 0, binding = 1) buffer Aux { GeoAux aux[]; };
layout(set = 0, binding = 2) buffer Radiance { vec4 radiance[]; };  // two per texel: front, back

GeoCluster geo_cluster(uint i, uint c) {
    return c == 0u ? geo[i].front : geo[i].back;
}

vec3 cluster_radiance(uint i, uint c) {
    return radiance[2u * i + c].rgb;
}
#endif

const uint MODE_HIERARCHICAL = 0u;
const uint MODE_BRUTE = 1u;

layout(push_constant) uniform SsbcPush {
    vec4 camera_position;     // xyz eye; w pixel side s on the image plane at distance 1
    vec4 camera_forward;      // xyz unit optical axis; w focal length in pixels (1 / s)
    vec4 camera_up;           // xyz unit up direction of the image (orthogonal to the axis)
    uvec2 size;               // image size
    uvec2 pyramid_size;       // level 0 of the pyramids (padded)
    uint levels;              // pyramid levels
    uint level;               // level a pyramid build writes, or evaluation points are taken from
    uint eval_level;          // coarsest level of evaluation points
    uint mode;                // MODE_*
    float bound;              // b [1/m^2]
    float refine_ratio;       // refine a texel whose sphere radius exceeds this x its distance
    float min_cos_view;       // lower clamp of cos(theta_view) in A_y
    float max_normal_spread;  // continuous: |mean of unit normals| at least this
    float max_thickness;      // continuous: slab half-thickness at most this x the radius
    float texels_per_radius;  // evaluation texels wanted across the bounding radius 1/sqrt(b)
    float scale_fraction;     // interpolate over at most this x a point's variation scale
    uint generation;          // evaluation points of this step carry this stamp
    uint from_list;           // 1: work items come from a list; 0: every texel of `level`
    float refine_excess;      // ...only if G may exceed (1 + this) b somewhere in it
    uint layers;              // bits 0..3: pyramids the residual gathers from (1, or 2 with a
                              // second layer); bits 4..7: log2 of layer 1's pixel side
    uint build_layer;         // the pyramid the build kernels (and texel_index) address
} pc;

// One layer's pyramid: where it starts in the buffers, its level 0 (padded)
// and its levels. Layer 1 is at full or half resolution: at half, its pixel
// p covers the full-resolution pixels 2p .. 2p + 1.
struct Pyramid {
    uint base;
    uvec2 size;
    int levels;
    int shift;                // log2 of its pixel's side in image pixels
};

// First texel of level l in a pyramid of n texels at level 0: after
// n + n/4 + ... + n/4^(l-1) = (4n - 4 n/4^l) / 3 texels; the division by 3
// is a multiply-high (exact below 2^32), which keeps integer division out
// of the traversal's inner loop.
uint level_start(uint n, int l) {
    uint high, low;
    umulExtended(4u * n - 4u * (n >> (2 * l)), 0xaaaaaaabu, high, low);
    return high >> 1;
}

// Pyramids the residual gathers from.
uint layer_count() {
    return pc.layers & 15u;
}

// log2 of a layer's pixel side in image pixels (layer 0: 0).
uint layer_shift(uint layer) {
    return layer == 0u ? 0u : (pc.layers >> 4) & 15u;
}

Pyramid pyramid_of(uint layer) {
    if (layer == 0u) return Pyramid(0u, pc.pyramid_size, int(pc.levels), 0);
    uint n = pc.pyramid_size.x * pc.pyramid_size.y;
    uint shift = layer_shift(layer);
    return Pyramid(level_start(n, int(pc.levels)), pc.pyramid_size >> shift, int(pc.levels - shift), int(shift));
}

// The size of an image whose pixel side is 2^shift image pixels (rounded up).
uvec2 image_size_at(uint shift) {
    return (pc.size + (1u << shift) - 1u) >> shift;
}

// The image size of a layer.
uvec2 layer_image_size(uint layer) {
    return image_size_at(layer_shift(layer));
}

// Index of texel t of level l of pyramid p in the buffers.
uint texel_index_in(Pyramid p, ivec2 t, int l) {
    return p.base + level_start(p.size.x * p.size.y, l) + uint(t.y) * (p.size.x >> l) + uint(t.x);
}

// Texels of level l of the pyramid pc.build_layer names.
ivec2 level_size(int l) {
    return ivec2(pyramid_of(pc.build_layer).size) >> l;
}

// Index of texel t of level l of the pyramid pc.build_layer names.
uint texel_index(ivec2 t, int l) {
    return texel_index_in(pyramid_of(pc.build_layer), t, l);
}

// The pixel that is the evaluation point of texel t of level l: the one at
// offset (2^(l-1), 2^(l-1)) in its block, a real surface point on a regular
// grid (pixels between four points interpolate bilinearly).
ivec2 eval_pixel(ivec2 t, int l) {
    return (t << l) + ((1 << l) >> 1);
}

// Work lists (pixels or texels, packed x | y << 16) with the arguments of
// the indirect dispatch that processes them, 64 items per work group.
struct ListHeader {
    uint dispatch_x;
    uint dispatch_y;
    uint dispatch_z;
    uint count;
};

uint pack_item(ivec2 p) {
    return uint(p.x) | (uint(p.y) << 16);
}

ivec2 unpack_item(uint v) {
    return ivec2(v & 0xffffu, v >> 16);
}

// World-space area seen through a pixel at `position` with unit normal n:
// A = t^2 Omega_px / max(cos theta_view, min_cos_view), Omega_px = s^2 cos^3(alpha).
float pixel_area(vec3 position, vec3 n) {
    vec3 v = position - pc.camera_position.xyz;
    float t = length(v);
    vec3 dir = v / t;
    float cos_alpha = dot(dir, pc.camera_forward.xyz);
    float s = pc.camera_position.w;
    float cos_view = max(abs(dot(n, dir)), pc.min_cos_view);
    return t * t * s * s * cos_alpha * cos_alpha * cos_alpha / cos_view;
}

// Conservative screen radius (pixels) of the sphere of radius r around x.
float screen_radius(vec3 x, float r) {
    vec3 v = x - pc.camera_position.xyz;
    float z = dot(v, pc.camera_forward.xyz);
    float cos_alpha = z / length(v);
    float radius_px = float(max(pc.size.x, pc.size.y));
    if (z - r > 1e-4) {
        radius_px = min(radius_px, pc.camera_forward.w * r / ((z - r) * cos_alpha * cos_alpha) + 1.0);
    }
    return radius_px;
}

// The residual integral, kept linear in the receiver's normal: over the y
// where G(x, y) > b,
//   I_c(x) = sum max(G - b, 0) A_y S_c(y) = n_x . V_c - b C_c,
//   V_c = sum (w cos(theta_y) / d^2) A_y S_c(y),  C_c = sum A_y S_c(y)
// (w = (y - x) / d). Per colour channel c: xyz V_c, w C_c. A pixel whose
// normal differs a little from an evaluation point's gets n . V - b C, right
// to first order (the set where G > b moves only where G - b is near 0).
struct Residual {
    vec4 r;
    vec4 g;
    vec4 b;
};

// Adds y (at d = y - x, normal ny, sum of A_y S(y) `as`) if G > b there.
// `ny` may be shorter than 1 (a mean of spread normals): cos(theta_y) is
// then the area-weighted mean of the cosines. Returns what it added per unit
// of A_y S(y), max(G - b, 0).
float accumulate(inout Residual acc, vec3 nx, vec3 ny, vec3 d, float dist, vec3 as) {
    vec3 w = d / dist;
    float cos_x = dot(nx, w);
    float k = max(-dot(ny, w), 0.0) / (dist * dist);
    if (!(cos_x * k > pc.bound)) return 0.0;
    vec3 wk = w * k;
    acc.r += vec4(wk * as.r, as.r);
    acc.g += vec4(wk * as.g, as.g);
    acc.b += vec4(wk * as.b, as.b);
    return cos_x * k - pc.bound;
}

// I(x) for the normal n from the linear form.
vec3 residual_at(Residual acc, vec3 n) {
    return max(vec3(dot(n, acc.r.xyz) - pc.bound * acc.r.w,
                    dot(n, acc.g.xyz) - pc.bound * acc.g.w,
                    dot(n, acc.b.xyz) - pc.bound * acc.b.w), vec3(0.0));
}

// What a contribution c at distance 1 / inv_d adds to the sums (sum c,
// sum c / d) whose ratio is the variation scale (see residual_integral).
void add_to_scale(inout vec2 scale, float c, float inv_d) {
    scale += vec2(c, c * inv_d);
}

// Adds cluster c of level-0 texel i (a pixel's own surface, or its part
// beyond a crease) if G > b there (brute force).
void add_pixel_cluster(inout Residual acc, uint i, uint c, vec3 x, vec3 nx, float r_world, inout vec2 scale) {
    GeoCluster g = geo_cluster(i, c);
    vec3 d = g.position_extent.xyz - x;
    float d2 = dot(d, d);
    if (cluster_extent(g).y >= 0.0 && d2 < r_world * r_world && d2 >= 1e-12) {
        vec3 as = cluster_radiance(i, c);
        float dist = sqrt(d2);
        float excess = accumulate(acc, nx, g.normal_cone.xyz, d, dist, as);
        add_to_scale(scale, excess * (as.r + as.g + as.b), 1.0 / dist);
    }
}

// lavapipe ends a shader invocation's loops after 65535 iterations in all
// (LP_MAX_TGSI_LOOP_ITERATIONS, shared by every loop a SIMD group runs). A
// loop cut short that way (it visited fewer pixels or roots than its window
// holds; its own exit condition cannot tell, the compiler folds it) ORs
// CUT_SHORT into `count`, and the renderer reports an error instead of
// returning a partial sum.
const uint CUT_SHORT = 1u << 30;

// The brute-force loop takes BRUTE_SPAN pixels of a row per iteration,
// unrolled. One per iteration cut windows short from a radius of about 128
// pixels, 90 with two layers (tori 640x480: half the residual missing; 320x240
// with two layers: 1.2% relative RMSE against the CPU twin); 16 fit a
// 1024x768 window of one layer, or of two with a radius up to about 500
// pixels. (Blocks of 4 x 16 took 12 s more to compile.)
const int BRUTE_SPAN = 16;

// Every texel of level 0 of pyramid p in the window (the reference);
// `center` and `radius_px` in that pyramid's pixels.
void integrate_brute(inout Residual acc, Pyramid p, vec3 x, vec3 nx, vec2 center, float radius_px, float r_world,
                     inout uint count, inout vec2 scale) {
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
                add_pixel_cluster(acc, i, 0u, x, nx, r_world, scale);
                add_pixel_cluster(acc, i, 1u, x, nx, r_world, scale);
            }
        }
        q = q.x + BRUTE_SPAN <= hi.x ? ivec2(q.x + BRUTE_SPAN, q.y) : ivec2(lo.x, q.y + 1);
        more = q.y <= hi.y;
    }
    if (count - start != window) count |= CUT_SHORT;
}

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
};

// Adding a cluster from its mean takes max(G - b, 0) at the mean for the
// mean of max(G - b, 0) over its pixels: always too little (max is convex),
// by up to half of how much G varies over the cluster where G ~ b there,
// which left the hierarchical residual 0.5 to 1.3% short of brute force at
// refine_ratio 0.2. G = cos_x cos_y / d^2 changes by about
//   s = SPREAD (R / d) (2 G + (cos_x + cos_y) / d^2)
// across a cluster of bounding radius R (first order in R / d). Taking G
// spread evenly over [G - s, G + s], the mean of max(G - b, 0) is, with
// m = G - b and t = (m + s) / 2s in [0, 1]:
//   m (m >= s),  (m + s)^2 / 4s = t/2 (G - b) + t/2 s (|m| < s),  0 (m <= -s).
// SPREAD (the pixels' r.m.s. offset over R, about) was chosen so that the
// mean of the residual matches brute force within 0.5% on the built-in
// scenes and the open box at 256x192 to 640x480 (0.6 overshot by 1-3%).
const float SPREAD = 0.3;

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
    vec2 extent = cluster_extent(g);  // radius, thickness
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
    if (d_min > 0.0) {
        // G <= cos_x / d_min^2 = min(d_min, reach) / d_min^3, and the cone's
        // bound on cos_y; compared as G d_min^3 (no division).
        float cube = d_min * d_min * d_min;
        float g_cube = min(d_min, reach);
        g_cube = g_cube <= pc.bound * cube ? g_cube : g_cube * max_cos_y(axis, g.normal_cone.w, d, inv_dist, extent.x);
        skip = skip || g_cube <= pc.bound * cube;
        may_exceed = g_cube > (1.0 + pc.refine_excess) * pc.bound * cube;
    }
    // The mean's own geometry term, k = cos(theta_y) / d^2, and the mean of
    // max(G - b, 0) over the cluster (see SPREAD; s = 0 for a pixel).
    float k = max(-dot(ny, d), 0.0) * inv_dist * inv_dist * inv_dist;
    float g_mean = along * inv_dist * k;
    float m = g_mean - pc.bound;
    float s = SPREAD * extent.x * inv_dist * (2.0 * abs(g_mean) + (abs(along) * inv_dist + k * d2) * inv_dist * inv_dist);
    float t = clamp((m + s) / max(2.0 * s, 1e-30), 0.0, 1.0);
    bool straddles = m < s && s > 0.0;
    float weight = dist > 1e-6 ? (straddles ? 0.5 * t : (m > 0.0 ? 1.0 : 0.0)) : 0.0;
    int action = skip ? SKIP : (level > 0 && extent.x > pc.refine_ratio * dist && may_exceed ? REFINE : ADD);
    // The straddling term t/2 s is constant: n . n = 1 carries it in V.
    vec3 wk = weight * (d * (inv_dist * k) + (straddles ? s : 0.0) * nx);
    return Visit(action, wk, weight, inv_dist);
}

// Adds a visited cluster from its means: the mean of max(G - b, 0) over it
// times sum(A_y S(y)), kept linear in the receiver's normal nx.
void add_visit(inout Residual acc, Visit v, vec3 as, vec3 nx, inout vec2 scale) {
    if (v.action == ADD && v.weight > 0.0) {
        acc.r += vec4(v.wk * as.r, v.weight * as.r);
        acc.g += vec4(v.wk * as.g, v.weight * as.g);
        acc.b += vec4(v.wk * as.b, v.weight * as.b);
        add_to_scale(scale, max(dot(nx, v.wk) - pc.bound * v.weight, 0.0) * (as.r + as.g + as.b), v.inv_dist);
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
    ivec2 hi = min(ivec2(ceil(c + r)) >> level, (ivec2(p.size) >> level) - 1);
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

// The lowest set bit of a 4-bit mask m != 0, from a table (2 bits per m).
// With findLSB here and below, the two-layer step on tori 1024x768 took
// 1000 ms against 947 (one alternating run).
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
// in all, not the sum of each layer's busiest (tori 1024x768, two full
// layers: step 1.76x -> 1.67x one layer's). Every texel read is counted.
// A texel is refined if either of its clusters needs refining; otherwise
// its clusters are added or skipped. A refined texel's children are
// visited unless they only hold members of a cluster that was skipped
// (G <= b over all of it): at a silhouette one cluster is often near x and
// the other beyond the bounding radius or behind x's tangent plane (tori
// 1024x768: 65.2 -> 56.4 texels read per pixel with two layers, 35.1 ->
// 32.7 with one).
// The walk is one flat loop without a stack of texels (and without
// break/continue, which lavapipe's SIMD loops have mishandled): the padded
// pyramid gives every texel four children, visited in the order (0,0)
// (1,0) (0,1) (1,1) as far as the level's bits in `children` say; after a
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
        GeoCluster front_cluster = geo_cluster(i, 0u);
        Visit front = visit(front_cluster, x, nx, r_world, t.z);
        Visit back = visit(geo_cluster(i, 1u), x, nx, r_world, t.z);
        uint bits = children_bits(front_cluster);
        uint visit_children = (front.action != SKIP ? bits & 15u : 0u) | (back.action != SKIP ? bits >> 4 : 0u);
        bool refine = (front.action == REFINE || back.action == REFINE) && visit_children != 0u;
        if (!refine) {
            add_visit(acc, front, cluster_radiance(i, 0u), nx, scale);
            add_visit(acc, back, cluster_radiance(i, 1u), nx, scale);
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
    float r_world = inversesqrt(pc.bound);
    variation = r_world;
    if (!(r_world > 0.0)) return acc;
    float radius_px = screen_radius(x, r_world);
    vec2 scale = vec2(0.0);
    // Every layer's surfaces are sources (the separation between layers
    // keeps one surface from being counted twice); at half resolution
    // layer 1's window is half as many pixels across.
    if (pc.mode == MODE_BRUTE) {
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

// An evaluation point (ssbc_eval.comp), one per texel of every level, in the
// pyramid's layout: the residual's linear form, texels read (< 0: unusable),
// its variation scale (see residual_integral), and the generation of
// the step that asked for it (points of other steps are stale).
struct EvalPoint {
    Residual residual;
    float reads;
    float variation;
    uint generation;
    uint pad;
};

// Evaluation point `index` from a texel view of the points (four
// R32G32B32A32_UINT texels per point; see SSBC_READ_PYRAMIDS for why).
EvalPoint load_point(usamplerBuffer texels, uint index) {
    int at = int(4u * index);
    uvec4 tail = texelFetch(texels, at + 3);
    return EvalPoint(Residual(uintBitsToFloat(texelFetch(texels, at)),
                              uintBitsToFloat(texelFetch(texels, at + 1)),
                              uintBitsToFloat(texelFetch(texels, at + 2))),
                     uintBitsToFloat(tail.x), uintBitsToFloat(tail.y), tail.z, tail.w);
}

#endif
