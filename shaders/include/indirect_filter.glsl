// Reconstruction of the interleaved bounded VPL lighting (Segovia et al.
// 2006). Every N x N box of pixels holds each of the N^2 positions in a
// block, i.e. each VPL subset, exactly once, so the mean of the interleaved
// sums (N^2 x one subset's sum) over a box on one surface is the sum over
// every VPL. Each pixel takes, of the N^2 boxes that contain it, the one
// with most pixels on its own surface (shading normals within
// acos(min_normal_cos), within max_plane_slope x their distance of its
// tangent plane, the geometric normal's: a normal map turns the shading
// normal, not the surface the neighbours lie on; reached by the same
// punctual lights, unless their light differs little: lights_part; ties
// go to the most central box), and averages those pixels: across depth
// and normal discontinuities nothing is mixed, and beside an edge the box
// turns away from it, so the pixel still sees every subset. Only where no
// box lies on its surface (corners, features thinner than N pixels) do
// some subsets go missing. Where the whole (2N - 1)^2 window is on the
// surface, tent weights (N - |dx|)(N - |dy|) instead: each subset's total
// weight is still N^2, and its pixels' offsets average to zero. Then the
// receiver's diffuse colour, the glossy rest, S0 and what it sends as a
// source.
//
// A pixel beside a crease or contact (a neighbour of another surface
// within crease_footprints x its footprint in space), or whose glossy lobe
// turns across the window by more than lobe_turn x its width (RIM_TURN x
// that beside another surface), is listed for indirect_creases.comp,
// which evaluates every VPL there.
#include "common.glsl"
#include "interleaved_sums.glsl"
#include "brdf.glsl"
#include "geometric_normal.glsl"
#ifdef EXACT_VISIBILITY
#include "exact_visibility.glsl"
#endif

const int MAX_SIDE = 4;
// Beside another surface or the background (a pixel of the window that is
// not on the receiver's surface) the lobe may turn RIM_TURN x lobe_turn:
// where a glossy object turns away from the eye its lobe turns fastest and
// its neighbours lie on one side only, and averaging them speckled its last
// 1-3 pixels (measured: docs/accuracy.md, "Tuned constants").
const float RIM_TURN = 0.5;
const int MAX_WINDOW = 2 * MAX_SIDE - 1;
// Neighbours that other punctual lights reach stay apart where their mean
// bounded light and that of the pixel's side differ by more than this
// factor (lights_part). 4 parted the 1 mm rooms at 96x72 but not at
// 384x288, where the ISMs' own leak brightens the unlit side beside the
// wall (docs/accuracy.md, "The filter parts what different lights reach").
const float LIGHTS_APART = 2.0;
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rg32ui) uniform readonly uimage2D g_albedo;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D direct;
layout(set = 0, binding = 3, rgba32ui) uniform readonly uimage2D interleaved;  // pack_sums (interleaved_sums.glsl)
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D s0;
// (dispatch x, y, z, count), then x | y << 16 per pixel.
layout(set = 0, binding = 6) buffer Creases { uvec4 header; uint pixels[]; } creases;
layout(set = 0, binding = 8, rgba32f) uniform readonly image2D direct_sources;
layout(set = 0, binding = 9, rgba32f) uniform writeonly image2D s0_sources;
layout(set = 0, binding = 10, rg32ui) uniform readonly uimage2D g_normal;
layout(set = 0, binding = 11, rgba32f) uniform readonly image2D g_emission; // w: geometric normal
// Which punctual lights reach each pixel (direct_lighting.comp).
layout(set = 0, binding = 12, r32ui) uniform readonly uimage2D direct_lights;

// What the filter's surface tests read of a pixel: the G-buffer's
// position and shading normal. (A guide image of both in one texel, one
// load per tap, took 16 bytes a pixel more of the gather's phase.)
struct Guide {
    vec3 position;
    vec3 normal;
    bool geometry;
};

Guide guide_at(ivec2 q) {
    vec4 x = imageLoad(g_position, q);
    Guide g;
    g.position = x.xyz;
    g.geometry = x.w != 0.0;
    g.normal = g.geometry ? unpack_gbuffer_normal(imageLoad(g_normal, q)).xyz : vec3(0.0);
    return g;
}

// Writes S0, the direct light plus the pixel's bounded indirect light from
// the filtered sums (the diffuse part per unit diffuse colour, irradiance /
// pi; the glossy rest), and adds what the pixel sends as a source
// (brdf_source_color) to the direct light's (s0_sources is that image: the
// pixel's own texel, read then written once).
void store(ivec2 pixel, vec4 direct_radiance, vec3 sum, vec3 glossy, float weight) {
    Brdf b = brdf_from_gbuffer(unpack_gbuffer_albedo(imageLoad(g_albedo, pixel)), unpack_gbuffer_normal(imageLoad(g_normal, pixel)));
    vec3 radiance = brdf_diffuse_color(b) * sum / weight + glossy / weight;
    imageStore(s0, pixel, vec4(direct_radiance.rgb + radiance, 1.0));
    vec3 source = brdf_source_color(b) * sum / weight;
    vec4 own = imageLoad(direct_sources, pixel);  // w: the geometric normal, kept
    imageStore(s0_sources, pixel, vec4(own.rgb + source, own.w));
}

layout(push_constant) uniform FilterPush {
    uvec2 size;
    int side;               // N <= MAX_SIDE
    float min_normal_cos;
    float max_plane_slope;
    float crease_footprints;
    float lobe_turn;        // a lobe turning more (/ alpha) evaluates every VPL
    vec4 camera_position;   // xyz: the eye; w: the scene's diagonal, at most 1 m (exact_lift)
} pc;

// The mirror direction of the view at x (normal n).
vec3 mirror(vec3 x, vec3 n) {
    return reflect(normalize(x - pc.camera_position.xyz), n);
}

// The filter's surface test: a point at offset d (|d| = distance) with
// normal `other` lies on the surface of the plane normal `plane` and the
// shading normal n.
bool on_surface(vec3 plane, vec3 n, vec3 d, float distance, vec3 other) {
    return abs(dot(plane, d)) <= pc.max_plane_slope * distance && dot(n, other) >= pc.min_normal_cos;
}

#ifdef EXACT_VISIBILITY
// A wall thinner than the surface tests resolve (two rooms' floors either
// side of it) separates a pixel from neighbours on its plane. Rays between
// adjacent pixels find it: one per pair in the work group's tile and its
// apron, shared through `links` by every window that holds the pair (a ray
// from each pixel to each neighbour cast 48 per pixel, 8x these), and a
// neighbour counts as the pixel's surface only if a chain of free links
// reaches it within the window.
const int APRON = MAX_SIDE - 1;
const int TILE = 8 + 2 * APRON;
// Per pixel of the tile: bit 0, nothing between it and its right
// neighbour; bit 1, nor its lower one (both on one surface).
shared uint links[TILE * TILE];

// Whether pixels a and b are on one surface (the filter's tests, from a).
bool same_surface(Guide a, Guide b) {
    if (!b.geometry) return false;
    vec3 d = b.position - a.position;
    return on_surface(a.normal, a.normal, d, length(d), b.normal);
}

// Casts the tile's links (every invocation of the group takes part).
void cast_links() {
    ivec2 origin = ivec2(gl_WorkGroupID.xy) * 8 - APRON;
    for (int i = int(gl_LocalInvocationIndex); i < TILE * TILE; i += 64) {
        ivec2 t = ivec2(i % TILE, i / TILE);
        ivec2 c = origin + t;
        uint bits = 0u;
        if (all(greaterThanEqual(c, ivec2(0))) && all(lessThan(uvec2(c), pc.size))) {
            Guide a = guide_at(c);
            for (int k = 0; k < 2 && a.geometry; k++) {
                ivec2 step = k == 0 ? ivec2(1, 0) : ivec2(0, 1);
                ivec2 q = c + step;
                // (Links out of the tile are never read.)
                if (any(greaterThanEqual(t + step, ivec2(TILE))) || any(greaterThanEqual(uvec2(q), pc.size))) continue;
                Guide b = guide_at(q);
                if (same_surface(a, b) && segment_free(a.position, a.normal, b.position, b.normal, pc.camera_position.w)) {
                    bits |= 1u << uint(k);
                }
            }
        }
        links[i] = bits;
    }
    barrier();
}

// Which pixels of the (2 reach + 1)^2 window (bit dx of reached[dy]) free
// links join to its centre, the invocation's pixel.
void window_reached(int reach, out uint reached[MAX_WINDOW]) {
    ivec2 centre = ivec2(gl_LocalInvocationID.xy) + APRON;
    int side = 2 * reach + 1;
    uint right[MAX_WINDOW];
    uint down[MAX_WINDOW];
    for (int dy = 0; dy < side; dy++) {
        uint r = 0u;
        uint d = 0u;
        for (int dx = 0; dx < side; dx++) {
            ivec2 t = centre + ivec2(dx, dy) - reach;
            uint bits = links[t.y * TILE + t.x];
            r |= (bits & 1u) << uint(dx);
            d |= ((bits >> 1) & 1u) << uint(dx);
        }
        right[dy] = r;
        down[dy] = d;
        reached[dy] = 0u;
    }
    uint full = (1u << uint(side)) - 1u;
    reached[reach] = 1u << uint(reach);
    // Grown a step a round until nothing is added.
    for (int round = 0; round < side * side; round++) {
        bool grew = false;
        for (int dy = 0; dy < side; dy++) {
            uint c = reached[dy];
            uint grown = c | ((c & right[dy]) << 1) | ((c >> 1) & right[dy]);
            if (dy > 0) grown |= reached[dy - 1] & down[dy - 1];
            if (dy + 1 < side) grown |= reached[dy + 1] & down[dy];
            grown &= full;
            if (grown != c) {
                reached[dy] = grown;
                grew = true;
            }
        }
        if (!grew) break;
    }
}
#endif

// Whether the window's pixels on the pixel's surface that other punctual
// lights reach (bits of `others`; those its own lights reach: `rows`) stay
// apart from it. They lie beyond a shadow's edge, or beyond a wall the
// surface tests do not see (two rooms' coplanar floors either side of
// it). Beside a shadow's edge the indirect light is smooth, and they join
// the pixel's. Beyond a wall each side has VPLs of its own: where the two
// sides' mean sums differ by more than LIGHTS_APART they stay apart, and
// the box turns away from them as from any edge (not a crease). Each side
// must hold a row of the window's pixels, so that its mean averages
// enough subsets that noise alone seldom parts them.
bool lights_part(ivec2 pixel, int reach, uint rows[MAX_WINDOW], uint others[MAX_WINDOW]) {
    float own_sum = 0.0, apart_sum = 0.0;
    int own_count = 0, apart_count = 0;
    for (int dy = 0; dy <= 2 * reach; dy++) {
        for (int dx = 0; dx <= 2 * reach; dx++) {
            bool own_side = ((rows[dy] >> uint(dx)) & 1u) != 0u;
            bool other_side = ((others[dy] >> uint(dx)) & 1u) != 0u;
            if (!own_side && !other_side) continue;
            uvec4 sums = imageLoad(interleaved, pixel + ivec2(dx, dy) - reach);
            float l = dot(sums_diffuse(sums) + sums_glossy(sums), vec3(1.0));
            if (own_side) {
                own_sum += l;
                own_count++;
            } else {
                apart_sum += l;
                apart_count++;
            }
        }
    }
    if (min(own_count, apart_count) < 2 * reach + 1) return false;
    float own_mean = own_sum / float(own_count);
    float apart_mean = apart_sum / float(apart_count);
    return apart_mean > LIGHTS_APART * own_mean || own_mean > LIGHTS_APART * apart_mean;
}

void main() {
#ifdef EXACT_VISIBILITY
    cast_links();
#endif
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(pixel), pc.size))) return;
    Guide own = guide_at(pixel);
    vec4 direct_radiance = imageLoad(direct, pixel);
    if (!own.geometry) {
        imageStore(s0, pixel, vec4(direct_radiance.rgb, 0.0));
        imageStore(s0_sources, pixel, imageLoad(direct_sources, pixel));
        return;
    }
    vec3 x = own.position;
    vec3 n = own.normal;
    vec3 surface = geometric_normal(imageLoad(g_emission, pixel).w, n);
    int reach = pc.side - 1;
    uint lights = imageLoad(direct_lights, pixel).x;
#ifdef EXACT_VISIBILITY
    uint reached[MAX_WINDOW];
    window_reached(reach, reached);
#endif
    // Which pixels of the (2N - 1)^2 window around the pixel are on its
    // surface: bit dx of rows[dy].
    // Among the 8 neighbours: the nearest in space on the surface (per
    // pixel of offset: the footprint) and on another surface.
    uint rows[MAX_WINDOW];
    float footprint = 1e30;
    float other = 1e30;
    // How far the glossy lobe's axis turns across the surface's pixels
    // (chord of the mirror directions, ~ the angle).
    float roughness = unpack_gbuffer_normal(imageLoad(g_normal, pixel)).w;
    bool glossy_receiver = roughness >= 0.0;
    vec3 own_mirror = glossy_receiver ? mirror(x, n) : vec3(0.0);
    float turn = 0.0;
    bool edge = false;
    uint others[MAX_WINDOW];
    bool any_apart = false;
    for (int dy = 0; dy <= 2 * reach; dy++) {
        uint row = 0u;
        uint apart = 0u;
        for (int dx = 0; dx <= 2 * reach; dx++) {
            ivec2 offset = ivec2(dx, dy) - reach;
            ivec2 q = pixel + offset;
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(uvec2(q), pc.size))) continue;
            Guide g = guide_at(q);
            if (!g.geometry) {
                edge = true;
                continue;
            }
            vec3 d = g.position - x;
            float distance = length(d);
            bool adjacent = max(abs(offset.x), abs(offset.y)) == 1;
            float per_pixel = distance / length(vec2(offset));
            if (!on_surface(surface, n, d, distance, g.normal)) {
                if (adjacent) other = min(other, per_pixel);
                edge = true;
                continue;
            }
#ifdef EXACT_VISIBILITY
            // A wall between them (see cast_links): another surface. An
            // adjacent neighbour no chain reaches (around a thin feature
            // in front, at a corner of the surface) asks a ray of its own:
            // only it decides whether the pixel lies beside a crease.
            bool linked = ((reached[dy] >> uint(dx)) & 1u) != 0u;
            if (!linked && adjacent) linked = segment_free(x, surface, g.position, g.normal, pc.camera_position.w);
            if (!linked) {
                if (adjacent) other = min(other, per_pixel);
                edge = true;
                continue;
            }
#endif
            if (adjacent) footprint = min(footprint, per_pixel);
            if (glossy_receiver) turn = max(turn, length(mirror(g.position, g.normal) - own_mirror));
            // Reached by other lights: apart until lights_part decides.
            if (imageLoad(direct_lights, q).x != lights) {
                apart |= 1u << uint(dx);
                continue;
            }
            row |= 1u << uint(dx);
        }
        rows[dy] = row;
        others[dy] = apart;
        any_apart = any_apart || apart != 0u;
    }
    // Neighbours that other lights reach join the pixel's surface unless
    // the light parts them (lights_part).
    if (any_apart) {
        if (lights_part(pixel, reach, rows, others)) {
            edge = true;
        } else {
            for (int dy = 0; dy <= 2 * reach; dy++) rows[dy] |= others[dy];
        }
    }
    // A glossy lobe that turns across the window by a good part of its
    // width (GGX alpha: its half-vector's spread; curved surfaces, normal
    // maps) cannot be averaged over neighbours, whose lobes point
    // elsewhere: such a receiver evaluates every VPL too. A flat or finely
    // sampled surface keeps its neighbours however smooth it is.
    // Its width: GGX alpha as the gather widened it by the VPLs' radii
    // (the mean spread of the glossy light of the pixel's own subset).
    float alpha = max(roughness, BRDF_MIN_ROUGHNESS);
    float widened = sqrt(alpha * alpha * alpha * alpha + max(sums_widening(imageLoad(interleaved, pixel)), 0.0));
    bool narrow_lobe = glossy_receiver && turn > (edge ? RIM_TURN : 1.0) * pc.lobe_turn * min(widened, 1.0);
    if (other <= pc.crease_footprints * footprint || narrow_lobe) {
        uint slot = atomicAdd(creases.header.w, 1u);
        creases.pixels[slot] = uint(pixel.x) | uint(pixel.y) << 16;
        // A workgroup per 8 listed pixels (indirect_creases.comp), at most
        // the 65535 every device dispatches; groups loop over the rest.
        atomicMax(creases.header.x, min(slot / 8u + 1u, 65535u));
        return;
    }
    // Every pixel of the window on the surface: tent weights, centred (the
    // offsets of each subset's pixels average to zero: exact for lighting
    // that varies linearly across the window).
    uint full_row = (1u << uint(2 * reach + 1)) - 1u;
    bool complete = true;
    for (int dy = 0; dy <= 2 * reach; dy++) {
        complete = complete && rows[dy] == full_row;
    }
    vec3 sum = vec3(0.0);
    vec3 glossy = vec3(0.0);
    float weights = 0.0;
    if (complete) {
        for (int dy = 0; dy <= 2 * reach; dy++) {
            float wy = float(pc.side - abs(dy - reach));
            for (int dx = 0; dx <= 2 * reach; dx++) {
                float w = wy * float(pc.side - abs(dx - reach));
                ivec2 q = pixel + ivec2(dx, dy) - reach;
                uvec4 sums = imageLoad(interleaved, q);
                sum += w * sums_diffuse(sums);
                glossy += w * sums_glossy(sums);
                weights += w;
            }
        }
        store(pixel, direct_radiance, sum, glossy, weights);
        return;
    }
    // Otherwise the box (its corner (bx, by) in the window) with most such pixels.
    uint box_mask = (1u << uint(pc.side)) - 1u;
    int best = -1;
    float best_offcentre = 0.0;
    ivec2 best_box = ivec2(0);
    float centre = 0.5 * float(reach);
    for (int by = 0; by <= reach; by++) {
        for (int bx = 0; bx <= reach; bx++) {
            int count = 0;
            for (int dy = by; dy < by + pc.side; dy++) {
                count += bitCount(rows[dy] & (box_mask << uint(bx)));
            }
            float offcentre = abs(float(bx) - centre) + abs(float(by) - centre);
            if (count > best || (count == best && offcentre < best_offcentre)) {
                best = count;
                best_offcentre = offcentre;
                best_box = ivec2(bx, by);
            }
        }
    }
    for (int dy = best_box.y; dy < best_box.y + pc.side; dy++) {
        uint row = (rows[dy] >> uint(best_box.x)) & box_mask;
        for (int dx = 0; dx < pc.side; dx++) {
            if ((row & (1u << uint(dx))) == 0u) continue;
            ivec2 q = pixel + ivec2(best_box.x + dx, dy) - reach;
            uvec4 sums = imageLoad(interleaved, q);
            sum += sums_diffuse(sums);
            glossy += sums_glossy(sums);
        }
    }
    // The pixel itself is in every box: best >= 1.
    store(pixel, direct_radiance, sum, glossy, float(best));
}
