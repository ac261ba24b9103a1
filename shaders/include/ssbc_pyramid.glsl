// Screen-space bias compensation: the pyramids' data and layout, shared by
// every SSBC kernel. Mirrored by src/passes/ssbc/ (push.rs, pyramids.rs).
//
// The pyramids live in buffers read and written as texel buffers (never as
// storage buffers, whose size maxStorageBufferRange caps at 128 MiB on
// lavapipe: 1920x1080 needs more), level after level (level l of a W x H
// pyramid is ceil(W / 2^l) x ceil(H / 2^l) texels, nothing padded: a texel
// of the last row or column may have only one or two children, and the
// builds take the missing ones as empty; see level_start):
//   geo         what the traversal reads: each texel's surface as two clusters
//   aux         areas, pixels with geometry, continuity, how the children's
//               clusters were grouped (pyramid builds and evaluation points only)
//   radiance    sum of A_y S_{k-1}(y) per cluster (rebuilt every step; both
//               of a texel's in one texel, pack_radiance)
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
// This file: the layout functions that read the frame (`pc.frame`; the
// kernel declares its push block after including ssbc_types.glsl, then
// includes this). Bindings come from ssbc_pyramid_read.glsl (kernels that
// read the pyramids) or ssbc_pyramid_write.glsl (the builds).

#ifndef SSBC_PYRAMID_GLSL
#define SSBC_PYRAMID_GLSL

#include "brdf.glsl"

// Pyramids the residual gathers from.
uint layer_count() {
    return pc.frame.layers & 15u;
}

// log2 of a layer's pixel side in image pixels (layer 0: 0).
uint layer_shift(uint layer) {
    return layer == 0u ? 0u : (pc.frame.layers >> 4) & 15u;
}

// Layer 0's level starts: the first texel of level l, after the
// ceil(W / 2^k) x ceil(H / 2^k) texels of each level k < l (l up to
// `levels`: all of layer 0's texels). Summed once per invocation, on first
// use (a sum per texel index would run up to 12 iterations inside the
// walk's loop).
const int MAX_LEVELS = 12;
uint level_starts_[MAX_LEVELS + 1];
bool level_starts_ready_ = false;

uint level_start(int l) {
    if (!level_starts_ready_) {
        uint start = 0u;
        [[unroll]] for (int k = 0; k <= MAX_LEVELS; k++) {
            level_starts_[k] = start;
            ivec2 s = level_size_of(pc.frame.pyramid_size, k);
            start += k < int(pc.frame.levels) ? uint(s.x * s.y) : 0u;
        }
        level_starts_ready_ = true;
    }
    return level_starts_[l];
}

Pyramid pyramid_of(uint layer) {
    if (layer == 0u) return Pyramid(0u, pc.frame.pyramid_size, int(pc.frame.levels), 0);
    uint shift = layer_shift(layer);
    return Pyramid(level_start(int(pc.frame.levels)), uvec2(level_size_of(pc.frame.pyramid_size, int(shift))),
                   int(pc.frame.levels - shift), int(shift));
}

// Index of texel t of level l of pyramid p in the buffers (a layer at half
// resolution has layer 0's level sizes from level 1 on).
uint texel_index_in(Pyramid p, ivec2 t, int l) {
    return p.base + level_start(l + p.shift) - level_start(p.shift)
        + uint(t.y) * uint(level_size_of(p.size, l).x) + uint(t.x);
}

// The size of an image whose pixel side is 2^shift image pixels (rounded up).
uvec2 image_size_at(uint shift) {
    return (pc.frame.size + (1u << shift) - 1u) >> shift;
}

// The image size of a layer.
uvec2 layer_image_size(uint layer) {
    return image_size_at(layer_shift(layer));
}

// Texels of level l of layer `layer`'s pyramid.
ivec2 level_size(uint layer, int l) {
    return level_size_of(pyramid_of(layer).size, l);
}

// Index of texel t of level l of layer `layer`'s pyramid.
uint texel_index(uint layer, ivec2 t, int l) {
    return texel_index_in(pyramid_of(layer), t, l);
}

// Where texel i lies in the geometry and aux buffers. Level 0 of each
// layer takes one geometry word a texel and nothing in aux (its areas and
// flags are in its word, its position in the layer's G-buffer:
// ssbc_types.glsl, "Level 0"); the other levels three and one. In the order of the texel indices: layer 0's level 0,
// its levels 1 and up, then layer 1's (with a second layer). The level-0
// ranges are summed once per invocation, with the level starts: the walk
// maps every texel it reads.
uvec3 level0_ranges_;  // layer 0's level-0 texels, layer 1's first texel, its level-0 texels
bool level0_ranges_ready_ = false;

uvec3 level0_ranges() {
    if (!level0_ranges_ready_) {
        uint layer1 = 0u;
        if (layer_count() > 1u) {
            ivec2 s = level_size_of(pc.frame.pyramid_size, int(layer_shift(1u)));
            layer1 = uint(s.x * s.y);
        }
        level0_ranges_ = uvec3(pc.frame.pyramid_size.x * pc.frame.pyramid_size.y, level_start(int(pc.frame.levels)), layer1);
        level0_ranges_ready_ = true;
    }
    return level0_ranges_;
}

// Level-0 texels with an index below i.
uint level0_texels_before(uint i) {
    uvec3 r = level0_ranges();
    return min(i, r.x) + min(uint(max(int(i) - int(r.y), 0)), r.z);
}

// Whether texel i is at level 0 of its layer.
bool is_level0(uint i) {
    uvec3 r = level0_ranges();
    return i < r.x || i - r.y < r.z;
}

// The first geometry word of texel i.
int geo_word(uint i) {
    return int(3u * i - 2u * level0_texels_before(i));
}

// The aux texel of texel i (not at level 0).
int aux_texel(uint i) {
    return int(i - level0_texels_before(i));
}

// The radiance texel of texel i: both sums of a texel of levels 1 and up,
// or the front sums of two level-0 texels (`half_`: 0 the even index's, in
// xy; 1 the odd's, in zw). A pixel's back cluster is a neighbour's surface
// and carries its radiance: that neighbour's front sum, scaled by their
// areas (`level0_back_radiance`), so level 0 keeps 8 bytes a pixel.
int radiance_texel(uint i, out uint half_) {
    uvec3 r = level0_ranges();
    uint first_half = (r.x + 1u) >> 1;
    half_ = 0u;
    if (i < r.x) {
        half_ = i & 1u;
        return int(i >> 1);
    }
    uint base = first_half + (i - r.x);
    if (i < r.y) return int(base);
    uint j = i - r.y;
    if (j < r.z) {
        half_ = j & 1u;
        return int(first_half + (r.y - r.x) + (j >> 1));
    }
    return int(base - r.z + ((r.z + 1u) >> 1));
}

// The layer (0 or 1) and the pixel of level-0 texel i.
ivec2 level0_pixel(uint i, out uint layer) {
    uint first = pc.frame.pyramid_size.x * pc.frame.pyramid_size.y;
    layer = i < first ? 0u : 1u;
    uint width = layer == 0u ? pc.frame.pyramid_size.x : uint(level_size(1u, 0).x);
    uint j = layer == 0u ? i : i - level0_ranges().y;
    return ivec2(j % width, j / width);
}

// Texel i's neighbour k at level 0 (inside its layer's image).
uint level0_neighbour(uint i, uint k) {
    uint first = pc.frame.pyramid_size.x * pc.frame.pyramid_size.y;
    int width = i < first ? int(pc.frame.pyramid_size.x) : level_size(1u, 0).x;
    ivec2 d = CREASE_NEIGHBOURS[k];
    return uint(int(i) + d.y * width + d.x);
}

// Whether texel t of level l's evaluation pixel (eval_pixel) lies in the
// image: in the last row or column of a level that overhangs the image it
// may not (such a texel has no evaluation point).
bool eval_pixel_inside(ivec2 t, int l) {
    return all(lessThan(eval_pixel(t, l), ivec2(pc.frame.size)));
}

// Index of layer 0's evaluation point at texel t of level l >= 1. Points
// exist for levels 1 and up, after one another as in the pyramid: at level
// 0 a pixel is evaluated alone (ssbc_fallback.glsl), so the buffers hold a
// third of the texels (1920x1080: 88 instead of 352 MB).
uint point_index(ivec2 t, int l) {
    return texel_index(0u, t, l) - level_start(1);
}

// World-space area seen through a pixel at `position` with unit normal n:
// A = t^2 Omega_px / max(cos theta_view, min_cos_view), Omega_px = s^2 cos^3(alpha).
float pixel_area(vec3 position, vec3 n) {
    vec3 v = position - pc.frame.camera_position.xyz;
    float t = length(v);
    vec3 dir = v / t;
    float cos_alpha = dot(dir, pc.frame.camera_forward.xyz);
    float s = pc.frame.camera_position.w;
    float cos_view = max(abs(dot(n, dir)), pc.frame.min_cos_view);
    return t * t * s * s * cos_alpha * cos_alpha * cos_alpha / cos_view;
}

// Conservative screen radius (pixels) of the sphere of radius r around x.
float screen_radius(vec3 x, float r) {
    vec3 v = x - pc.frame.camera_position.xyz;
    float z = dot(v, pc.frame.camera_forward.xyz);
    float cos_alpha = z / length(v);
    float radius_px = float(max(pc.frame.size.x, pc.frame.size.y));
    if (z - r > 1e-4) {
        radius_px = min(radius_px, pc.frame.camera_forward.w * r / ((z - r) * cos_alpha * cos_alpha) + 1.0);
    }
    return radius_px;
}

// A receiver's BRDF from its G-buffer albedo and normal: glTF
// metallic-roughness where the frame says the w channels hold it, else
// Lambertian of the albedo.
Brdf receiver_brdf(vec4 albedo, vec4 normal) {
    if ((pc.frame.layers & GLOSSY_RECEIVERS) != 0u) return brdf_from_gbuffer(albedo, normal);
    return brdf_lambertian(albedo.rgb);
}

// How much a nearly Lambertian receiver's BRDF may vary (times the cosine,
// relative to its value along the normal) over the directions light arrives
// from for it to take the residual's linear form from evaluation points
// like a Lambertian one (measured: docs/accuracy.md, "Tuned constants").
const float NEARLY_LAMBERTIAN = 0.15;

// Whether f(wo, .) of a glossy receiver differs from its value for light
// along the normal by at most NEARLY_LAMBERTIAN of that, weighted by the
// cosine a source's light arrives with (grazing light brings little),
// checked where a dielectric's lobe is highest (the mirror direction, 80
// degrees from the normal on the mirror's side, back along wo): rough
// dielectrics (glTF materials with metallic 0 and a high roughness) are;
// metals never are. Over the channels together: a dark channel's spread
// matters as much as its share of the pixel's light.
bool nearly_lambertian(Brdf b, vec3 n, vec3 wo) {
    if (b.metallic > 0.0) return false;
    vec3 mirror = reflect(-wo, n);
    vec3 t = mirror - n * dot(n, mirror);
    t = dot(t, t) > 1e-8 ? normalize(t) : normalize(cross(n, abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0)));
    vec3 f_n = brdf_eval(b, n, wo, n);
    float along_normal = f_n.r + f_n.g + f_n.b;
    float spread = 0.0;
    vec3 directions[3] = vec3[3](mirror, 0.985 * t + 0.174 * n, wo);
    for (int i = 0; i < 3; i++) {
        vec3 d = abs(brdf_eval(b, n, wo, directions[i]) - f_n);
        spread = max(spread, (d.r + d.g + d.b) * max(dot(n, directions[i]), 0.0));
    }
    return along_normal > 0.0 && spread <= NEARLY_LAMBERTIAN * along_normal;
}

// I(x) for the normal n from the linear form.
vec3 residual_at(Residual acc, vec3 n) {
    return max(vec3(dot(n, acc.r.xyz) - pc.frame.bound * acc.r.w,
                    dot(n, acc.g.xyz) - pc.frame.bound * acc.g.w,
                    dot(n, acc.b.xyz) - pc.frame.bound * acc.b.w), vec3(0.0));
}

#endif
