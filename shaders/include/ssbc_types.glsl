// Screen-space bias compensation: the data every SSBC kernel shares, and
// the pyramids' layout (see ssbc_pyramid.glsl). No bindings, no push block:
// a kernel includes this, declares its push block `pc` (with `SsbcFrame
// frame;` first, and `ResidualParams residual;` if it integrates), then
// ssbc_pyramid.glsl and the pyramids' bindings. Mirrored by
// src/passes/ssbc/ (push.rs, pyramids.rs).

#ifndef SSBC_TYPES_GLSL
#define SSBC_TYPES_GLSL

#extension GL_EXT_control_flow_attributes : require

#include "common.glsl"
#include "geometric_normal.glsl"
#include "octahedral.glsl"

// The frame as every SSBC kernel sees it (`pc.frame`; mirrored by
// `FrameBlock` in src/passes/ssbc/push.rs).
struct SsbcFrame {
    vec4 camera_position;     // xyz eye; w pixel side s on the image plane at distance 1
    vec4 camera_forward;      // xyz unit optical axis; w focal length in pixels (1 / s)
    vec4 camera_up;           // xyz unit up direction of the image (orthogonal to the axis)
    uvec2 size;               // image size
    uvec2 pyramid_size;       // level 0 of layer 0's pyramid (the image size)
    uint levels;              // pyramid levels
    uint layers;              // bits 0..3: pyramids the residual gathers from (1, or 2 with a
                              // second layer); bits 4..7: log2 of layer 1's pixel side;
                              // bit 8 (GLOSSY_RECEIVERS): the receivers' BRDF is in the
                              // G-buffer's w channels (brdf_from_gbuffer), else Lambertian;
                              // bit 9 (ONE_DISPATCH): glossy and other receivers' points and
                              // fallback pixels in one dispatch (ssbc_eval.glsl); bit 10
                              // (LAST_STEP): no later step reads what this one sends;
                              // bit 11 (NO_RESIDUAL): S_k is not kept in an image of its
                              // own (ssbc_output.glsl)
    float bound;              // b [1/m^2]
    float min_cos_view;       // lower clamp of cos(theta_view) in A_y
};

const uint GLOSSY_RECEIVERS = 256u;
const uint ONE_DISPATCH = 512u;
const uint LAST_STEP = 1024u;
const uint NO_RESIDUAL = 2048u;

// How the residual integral refines and integrates (`pc.residual`; mirrored
// by `ResidualParams` in src/passes/ssbc/push.rs).
struct ResidualParams {
    float refine_ratio;       // refine a texel whose sphere radius exceeds this x its distance
    float refine_excess;      // ...only if G may exceed (1 + this) b somewhere in it
    uint pad0;
    uint pad1;
};

// A cluster's radiance sum (`radiance` pyramid) in two words: three signed
// 18-bit mantissas and their shared exponent, within 2^-17 of the largest
// channel (half the bytes of three floats and their padding; sums under
// 2^-109 are flushed to zero). Powers of two are made from exponent bits:
// ldexp and frexp cost lavapipe calls.
uvec2 pack_radiance(vec3 v) {
    float largest = max(max(abs(v.r), abs(v.g)), abs(v.b));
    if (!(largest > 0.0) || isinf(largest)) return uvec2(0u);
    // largest = f 2^e with f in [0.5, 1).
    int e = clamp(int(floatBitsToUint(largest) >> 23) - 126, -108, 128);
    float to_mantissa = uintBitsToFloat(uint(144 - e) << 23);  // 2^(17 - e)
    ivec3 q = clamp(ivec3(round(v * to_mantissa)), ivec3(-131071), ivec3(131071));
    uvec3 m = uvec3(q) & 0x3FFFFu;
    return uvec2(m.r | (m.g << 18), (m.g >> 14) | (m.b << 4) | (uint(e + 108) << 22));
}

vec3 unpack_radiance(uvec2 w) {
    int r = bitfieldExtract(int(w.x), 0, 18);
    int g = bitfieldExtract(int((w.x >> 18) | (w.y << 14)), 0, 18);
    int b = bitfieldExtract(int(w.y), 4, 18);
    int e = int(w.y >> 22) - 108;
    return vec3(r, g, b) * uintBitsToFloat(uint(e + 110) << 23);  // 2^(e - 17)
}

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

// In memory a GeoTexel is three uvec4 words (48 bytes): the front
// cluster's position_extent, the back cluster's, then both normal_cones
// packed (front in .xy, back in .zw, pack_normal_cone).

// A texel's children (bit k: child k, in the order (0,0) (1,0) (0,1) (1,1))
// that hold members of its front (bits 0..3) and back (bits 4..7) cluster,
// kept in the low 8 mantissa bits of the front cluster's mean normal's z
// while in registers (in memory, a nibble of each cluster's packed
// normal): the traversal reads them with the texel, and skips the children
// that only hold members of clusters it skipped. Changing those bits moves
// the normal's direction by less than 2^-15 radians, well within the 1e-3
// radians its cone is widened by for rounding (ssbc_geometry_mips.comp).
// A z of 0 (axis-aligned normals are common) would become a denormal,
// which costs lavapipe's x86 code a microcode assist per operation
// (measured: docs/accuracy.md, "Tuned constants"): it becomes about 2^-60 first (its square is still a
// normal float).
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

// A cluster's normal_cone in two words, with a nibble of children bits:
// the mean normal's components (|n| <= 1) as signed 16-bit fixed point
// (within 1.6e-5, inside the 1e-3 radians cones are widened by for
// rounding), and the cone as sin(half-angle) in 12 bits, rounded up (a
// cone that is wider by at most 5e-4 radians still holds every member; a
// pixel's zero cone stays exact).
const float CONE_STEPS = 4095.0;

uvec2 pack_normal_cone(vec4 normal_cone, uint nibble) {
    vec3 n = normal_cone.xyz;
    float half_sine = sqrt(clamp(0.5 - 0.5 * normal_cone.w, 0.0, 1.0));
    uint cone = uint(min(ceil(half_sine * CONE_STEPS), CONE_STEPS));
    uint z = packSnorm2x16(vec2(n.z, 0.0)) & 0xFFFFu;
    return uvec2(packSnorm2x16(n.xy), z | (cone << 16) | (nibble << 28));
}

vec4 unpack_normal_cone(uvec2 w) {
    vec2 xy = unpackSnorm2x16(w.x);
    float z = unpackSnorm2x16(w.y).x;
    float half_sine = float((w.y >> 16) & 4095u) * (1.0 / CONE_STEPS);
    return vec4(xy, z, 1.0 - 2.0 * half_sine * half_sine);
}

// Cluster c (0 front, 1 back) from its position_extent word and its
// texel's packed normals (the front cluster with its children bits).
GeoCluster unpack_cluster(uvec4 position_extent, uvec4 normals, uint c) {
    GeoCluster g = GeoCluster(uintBitsToFloat(position_extent), unpack_normal_cone(c == 0u ? normals.xy : normals.zw));
    return c == 0u ? with_children_bits(g, (normals.y >> 28) | ((normals.w >> 28) << 4)) : g;
}

// The packed normals of a texel's clusters (children bits from the front's).
uvec4 pack_normals(GeoTexel t) {
    uint bits = children_bits(t.front);
    return uvec4(pack_normal_cone(t.front.normal_cone, bits & 15u), pack_normal_cone(t.back.normal_cone, bits >> 4));
}

// A cluster's (radius, thickness) are stored as halves in units of its
// depth: its distance in front of the eye along the view axis (clusters
// are made of the camera's pixels, so they lie in front of it). In metres
// they overflowed 65504 (a scene scaled 10^6 kept 8% of its residual) and
// lost bits under 6e-5; in units of depth they keep 11 bits at any scale.
float cluster_unit(vec3 position, vec3 eye, vec3 forward) {
    return max(dot(position - eye, forward), 1e-30);
}

// (radius, thickness) of a cluster in units of cluster_unit; the thickness
// is negative for no cluster.
vec2 cluster_extent(GeoCluster g) {
    return unpackHalf2x16(floatBitsToUint(g.position_extent.w));
}

// (radius, thickness) of a cluster in metres (eye and view axis as
// cluster_unit's).
vec2 cluster_extent_m(GeoCluster g, vec3 eye, vec3 forward) {
    return cluster_extent(g) * cluster_unit(g.position_extent.xyz, eye, forward);
}

// A cluster whose radius and thickness are given in units of `unit`
// (cluster_unit at `position`; 1 for extents of 0).
GeoCluster make_cluster(vec3 position, float radius, float thickness, vec3 normal, float cone_cos, float unit) {
    // Halves keep 11 bits: scale up by 2^-10 (and 1e-7 units for
    // subnormals) so that the stored bounds still hold.
    vec2 extent = vec2(radius, thickness) / unit;
    if (thickness >= 0.0) extent = extent * (1.0 + 1.0 / 1024.0) + 1e-7;
    return GeoCluster(vec4(position, uintBitsToFloat(packHalf2x16(extent))), vec4(normal, cone_cos));
}

GeoCluster empty_cluster() {
    return make_cluster(vec3(0.0), 0.0, -1.0, vec3(0.0), 1.0, 1.0);
}

// GeoAux.flags at level 0 of layer 0: the pixel is a glossy receiver that
// is not nearly Lambertian (its evaluation points need its BRDF).
const uint GLOSSY_RECEIVER = 32u;

struct GeoAux {
    float front_area;         // summed world-space area A_y of each cluster's pixels
    float back_area;
    uint pixels;              // pixels with geometry under the texel
    uint flags;               // bit 0: one smooth surface (may stand for its pixels);
                              // level 0, bits 1..4: k + 1 if the back cluster is the
                              // part of the pixel on neighbour CREASE_NEIGHBOURS[k]'s surface,
                              // bit 5 (GLOSSY_RECEIVER): a glossy receiver in layer 0;
                              // levels >= 1, bit 8 + 2k + c: cluster c of child k went
                              // to the back cluster
};

// The neighbours a pixel's footprint looks at (ssbc_geometry_base.comp).
const ivec2 CREASE_NEIGHBOURS[8] = ivec2[](ivec2(-1, 0), ivec2(1, 0), ivec2(0, -1), ivec2(0, 1),
                                           ivec2(-1, -1), ivec2(1, -1), ivec2(-1, 1), ivec2(1, 1));

// Level 0 (a pixel) in one uvec4 word instead of a GeoTexel's three and a
// GeoAux's one (16 instead of 64 bytes a pixel): a pixel has one cluster,
// with no extent or cone, at the pixel's own position, which the kernels
// read from the layer's G-buffer (level0_position, ssbc_pyramid_access.glsl),
// and at most the part beyond a crease on a neighbour's surface, whose
// normal and plane are that neighbour's.
//   x  the normal, octahedral (two snorm16; no cone, no children);
//   y  bits 0..24: the area A_y (a float's bits 6 and up, rounded: 17
//      mantissa bits); bits 25..30: GeoAux.flags (level 0 uses bits 0..5);
//   z, w  the back cluster's centroid in the neighbour's plane as two
//      21-bit floats (pack_f21) along orthonormal_basis of the neighbour's stored
//      normal, from the pixel's own position projected onto that plane: u
//      in z's bits 0..20, v's low 11 bits in z's 21..31 and its top 10 in
//      w's 22..31; w's bits 0..21: the back cluster's area (a float's bits
//      9 and up, rounded: 14 mantissa bits).
// The back cluster's position costs 42 bits instead of three floats:
// within 2^-15 of its distance from the pixel. (Measured from the
// neighbour's position instead, up to 30 times as far, in halves: the
// brute-force step moved by 2.9e-4 relative RMSE against the CPU twin,
// 8e-6 before; tests/ssbc.rs, tests/postprocess.rs.)

// A normal as level 0 stores it: octahedral, two signed 16-bit
// fixed-point numbers.
uint pack_level0_normal(vec3 n) {
    return packSnorm2x16(octahedral(n));
}

vec3 level0_normal(uvec4 w) {
    return from_octahedral(unpackSnorm2x16(w.x));
}

uint level0_flags(uvec4 w) {
    return (w.y >> 25) & 63u;
}

// A positive float without its `drop` lowest bits (rounded to nearest; a
// carry into the exponent is the rounding too).
uint pack_positive(float x, uint drop) {
    return (floatBitsToUint(max(x, 0.0)) + (1u << (drop - 1u))) >> drop;
}

float unpack_positive(uint bits, uint drop) {
    return uintBitsToFloat(bits << drop);
}

float level0_area(uvec4 w) {
    return unpack_positive(w.y & 0x1FFFFFFu, 6u);
}

float level0_back_area(uvec4 w) {
    return unpack_positive(w.w & 0x3FFFFFu, 9u);
}

// A float in 21 bits: its sign, a 6-bit exponent (2^-31 .. 2^32; smaller
// is 0, larger is clamped) and 14 mantissa bits rounded to nearest (within
// 2^-15 of it). By bits: a compiler may fold a pack and unpack of halves
// into nothing, and the rounding with it.
uint pack_f21(float x) {
    uint bits = floatBitsToUint(x);
    int e = int((bits >> 23) & 255u) - 127;
    uint m = ((bits & 0x7FFFFFu) + 256u) >> 9;  // 14 bits, rounded (may carry)
    e += int(m >> 14);
    m &= 0x3FFFu;
    if (e < -31) return 0u;
    if (e > 32) { e = 32; m = 0x3FFFu; }
    return ((bits >> 31) << 20) | (uint(e + 31) << 14) | m;
}

float unpack_f21(uint w) {
    uint e = (w >> 14) & 63u;
    if (e == 0u) return 0.0;
    return uintBitsToFloat(((w >> 20) << 31) | ((e - 31u + 127u) << 23) | ((w & 0x3FFFu) << 9));
}

// Where a back cluster's coordinates start: the pixel at `own` projected
// onto the plane of its neighbour at cq with stored (unit) normal nq.
vec3 back_origin(vec3 own, vec3 cq, vec3 nq) {
    return own - dot(own - cq, nq) * nq;
}

// The word of a pixel at `own` with normal n, area and flags; its back
// cluster at `back_position` with area back_area lies on the plane of the
// neighbour at cq whose stored normal is nq.
uvec4 pack_level0(vec3 own, vec3 n, float area, uint flags, vec3 back_position, vec3 cq, vec3 nq, float back_area) {
    uvec2 back = uvec2(0u);
    if (back_area > 0.0) {
        vec3 t1, t2;
        orthonormal_basis(nq, t1, t2);
        vec3 d = back_position - back_origin(own, cq, nq);
        back = uvec2(pack_f21(dot(d, t1)), pack_f21(dot(d, t2)));
    }
    return uvec4(pack_level0_normal(n), min(pack_positive(area, 6u), 0x1FFFFFFu) | (flags << 25),
                 back.x | (back.y << 21), min(pack_positive(back_area, 9u), 0x3FFFFFu) | ((back.y >> 11) << 22));
}

// The pixel's cluster (the front; with its children bits, none), at its
// position x.
GeoCluster level0_front(vec3 x, uvec4 w) {
    GeoCluster g = (level0_flags(w) & 1u) != 0u
        ? make_cluster(x, 0.0, 0.0, level0_normal(w), 1.0, 1.0)
        : empty_cluster();
    return with_children_bits(g, 0u);
}

// The neighbour code (k + 1 for CREASE_NEIGHBOURS[k]) of the pixel's back
// cluster, 0 if it has none.
uint level0_back_code(uvec4 w) {
    return (level0_flags(w) >> 1) & 15u;
}

// The pixel's back cluster, given its position and word (x, w) and its
// neighbour's (qx, qw).
GeoCluster level0_back(vec3 x, uvec4 w, vec3 qx, uvec4 qw) {
    if (level0_back_code(w) == 0u) return empty_cluster();
    vec3 nq = level0_normal(qw);
    vec3 t1, t2;
    orthonormal_basis(nq, t1, t2);
    float u = unpack_f21(w.z & 0x1FFFFFu);
    float v = unpack_f21((w.z >> 21) | ((w.w >> 22) << 11));
    vec3 origin = back_origin(x, qx, nq);
    return make_cluster(origin + u * t1 + v * t2, 0.0, 0.0, nq, 1.0, 1.0);
}

// The pixel's areas, pixels with geometry (0 or 1) and flags.
GeoAux level0_aux(uvec4 w) {
    uint flags = level0_flags(w);
    return GeoAux(level0_area(w), level0_back_area(w), flags & 1u, flags);
}

// One layer's pyramid: where it starts in the buffers, its level 0 and its
// levels. Level l is ceil(size / 2^l) texels (texel t of it covers the
// pixels t 2^l .. (t + 1) 2^l - 1; the last row and column may overhang the
// image, and a texel there has fewer than four children). Layer 1 is at
// full or half resolution: at half, its pixel p covers the full-resolution
// pixels 2p .. 2p + 1, and its level l is layer 0's level l + 1 in size.
struct Pyramid {
    uint base;
    uvec2 size;
    int levels;
    int shift;                // log2 of its pixel's side in image pixels
};

// Texels of level l of a pyramid whose level 0 is `size`.
ivec2 level_size_of(uvec2 size, int l) {
    return ivec2(((size - 1u) >> l) + 1u);
}

// The pixel that is the evaluation point of texel t of level l: the one at
// offset (2^(l-1), 2^(l-1)) in its block, a real surface point on a regular
// grid (pixels between four points interpolate bilinearly).
ivec2 eval_pixel(ivec2 t, int l) {
    return (t << l) + ((1 << l) >> 1);
}

// Work lists (pixels or texels, packed x | y << 16) with the arguments of
// the indirect dispatches that process them, 64 items per work group. A
// list may have two ends: items at glossy receivers (GLOSSY_RECEIVER) from
// the back (`back` of them, items[length - 1 - k]), the rest from the front
// (`count`), so that a work group, and every SIMD group in it, holds one
// kind of receiver. Three dispatches: both ends (the front's work groups
// first), the front alone, the back alone (a CPU device spends nearly a
// walk's time on a work group with nothing to do (measured: docs/accuracy.md, "Tuned constants")).
struct ListHeader {
    uint dispatch_x;          // VkDispatchIndirectCommand: both ends
    uint dispatch_y;
    uint dispatch_z;
    uint count;               // items at the front
    uint front_x;             // VkDispatchIndirectCommand: the front
    uint front_y;
    uint front_z;
    uint back;                // items at the back
    uint back_x;              // VkDispatchIndirectCommand: the back
    uint back_y;
    uint back_z;
    uint pad;
};

// Appends `item` to the front of a work list (a buffer block with a
// ListHeader `header` and `items`), growing its indirect dispatches by a
// work group for every 64 items.
#define APPEND_ITEM(list, item) {                           \
        uint slot_ = atomicAdd(list.header.count, 1u);      \
        list.items[slot_] = (item);                         \
        if (slot_ % 64u == 0u) {                            \
            atomicAdd(list.header.dispatch_x, 1u);          \
            atomicAdd(list.header.front_x, 1u);             \
        }                                                   \
    }

// Appends `item` to the back of a work list.
#define APPEND_ITEM_BACK(list, item) {                      \
        uint slot_ = atomicAdd(list.header.back, 1u);       \
        list.items[uint(list.items.length()) - 1u - slot_] = (item); \
        if (slot_ % 64u == 0u) {                            \
            atomicAdd(list.header.dispatch_x, 1u);          \
            atomicAdd(list.header.back_x, 1u);              \
        }                                                   \
    }

// Appends `item` to the back of a list if `at_back`, else to its front.
#define APPEND_ITEM_TO(list, item, at_back) {               \
        if (at_back) APPEND_ITEM_BACK(list, item) else APPEND_ITEM(list, item) \
    }

// Whether the kernel over a two-ended list takes both ends: a glossy
// kernel with ONE_DISPATCH in `layers` (else each kernel takes one end, the
// glossy ones the back).
bool takes_both_ends(bool glossy_kernel, uint layers) {
    return glossy_kernel && (layers & ONE_DISPATCH) != 0u;
}

// This invocation's item of a list dispatched indirectly, 64 invocations
// per work group: over both ends if `both_ends` (then `at_back` is set from
// the work group), else over the end `at_back` says. Sets `slot`, an index
// into items (~0u if none).
#define LIST_SLOT(list, slot, at_back, both_ends) {         \
        uint front_groups_ = (list.header.count + 63u) / 64u; \
        if (both_ends) at_back = gl_WorkGroupID.x >= front_groups_; \
        uint k_ = both_ends && at_back ? (gl_WorkGroupID.x - front_groups_) * 64u + gl_LocalInvocationID.x \
                                       : gl_GlobalInvocationID.x; \
        bool in_ = k_ < (at_back ? list.header.back : list.header.count); \
        slot = !in_ ? ~0u : at_back ? uint(list.items.length()) - 1u - k_ : k_; \
    }

uint pack_item(ivec2 p) {
    return uint(p.x) | (uint(p.y) << 16);
}

// Images are at most 32768 pixels a side, so an item's top bit is free: on
// the fallback list it marks a glossy pixel whose evaluation points stood
// for its Lambertian part but not its glossy rest (ssbc_resolve.comp).
const uint REST_ONLY = 1u << 31;

ivec2 unpack_item(uint v) {
    return ivec2(v & 0xffffu, (v >> 16) & 0x7fffu);
}

// The residual integral's linear form (see ssbc_residual.glsl): per colour
// channel c, xyz V_c and w C_c.
struct Residual {
    vec4 r;
    vec4 g;
    vec4 b;
};

// An evaluation point (ssbc_eval.comp), one per texel of every level, in the
// pyramid's layout: the residual's linear form, texels read (< 0: unusable),
// its variation scale (see residual_integral), and the generation of the
// step that asked for it (points of other steps are stale). The linear form
// is three RGBA32UI texels of `points`, the rest one RG32UI texel of
// `point_tails` (pack_point_tail): 56 bytes a point. With glossy
// receivers a third buffer (one RG32UI texel per point) holds, at a glossy
// receiver, the glossy rest of its own BRDF seen from the eye and the
// step's generation (pack_point_rest; 0 elsewhere).
struct EvalPoint {
    Residual residual;
    float reads;
    float variation;
    uint generation;
};

// A point's reads (float bits), and its variation scale (a non-negative
// float without its 9 lowest bits, rounded) under the generation (bits
// 23..31; steps are at most 16).
uvec2 pack_point_tail(EvalPoint p) {
    return uvec2(floatBitsToUint(p.reads), min(pack_positive(p.variation, 9u), 0x7FFFFFu) | (p.generation << 23));
}

// Evaluation point `index`'s tail alone (its residual zero).
EvalPoint load_point_tail(utextureBuffer tails, uint index) {
    uvec2 tail = texelFetch(tails, int(index)).xy;
    return EvalPoint(Residual(vec4(0.0), vec4(0.0), vec4(0.0)),
                     uintBitsToFloat(tail.x), unpack_positive(tail.y & 0x7FFFFFu, 9u), tail.y >> 23);
}

// Evaluation point `index` from texel views of the points (three
// R32G32B32A32_UINT texels per point) and of their tails (one R32G32_UINT).
EvalPoint load_point(utextureBuffer texels, utextureBuffer tails, uint index) {
    EvalPoint p = load_point_tail(tails, index);
    int at = int(3u * index);
    p.residual = Residual(uintBitsToFloat(texelFetch(texels, at)),
                          uintBitsToFloat(texelFetch(texels, at + 1)),
                          uintBitsToFloat(texelFetch(texels, at + 2)));
    return p;
}

// A glossy point's rest (pack_rgb56, common.glsl) with the step's
// generation in the top byte.
uvec2 pack_point_rest(vec3 rest, uint generation) {
    uvec2 w = pack_rgb56(rest);
    return uvec2(w.x, w.y | (generation << 24));
}

vec3 point_rest(uvec2 w) { return unpack_rgb56(uvec2(w.x, w.y & 0xFFFFFFu)); }
uint point_rest_generation(uvec2 w) { return w.y >> 24; }

// lavapipe ends a shader invocation's loops after 65535 iterations in all
// (LP_MAX_TGSI_LOOP_ITERATIONS, shared by every loop a SIMD group runs). A
// loop cut short that way (it visited fewer pixels or roots than its window
// holds; its own exit condition cannot tell, the compiler folds it) ORs
// CUT_SHORT into `count`, and the renderer reports an error instead of
// returning a partial sum.
const uint CUT_SHORT = 1u << 30;

#endif
