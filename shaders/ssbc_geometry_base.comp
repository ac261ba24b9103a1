#version 460
// SSBC geometry pyramid, level 0, from a G-buffer layer (pc.layer):
// each pixel's world position and unit normal as its front cluster, and the
// world-space area A_y it stands for. Kept apart from the coarser levels
// (ssbc_geometry_mips.comp): inside their kernel lavapipe ran this level
// slower, paying per invocation for code it does not run (measured: docs/accuracy.md, "Tuned constants").
//
// Footprints (full-resolution layers): a pixel stands for the surface seen through its
// square, on its tangent plane. Where the line along which that plane
// meets a neighbour's crosses the square between the two pixel centres (a
// crease: the two are one surface, not a silhouette), the part beyond the
// line is the neighbour's surface: it becomes the pixel's back cluster, at
// that part's centroid, with the neighbour's normal, and carries the
// neighbour's radiance (its offset in GeoAux.flags bits 1..4, read by
// ssbc_radiance_mips.comp). Pixel centres alone miss the strip of a grazing
// surface next to a crease, where G is largest (measured: docs/accuracy.md, "Tuned constants").
// Mirrored by `footprint` in src/cpu/ssbc.rs.
#include "ssbc_types.glsl"

layout(push_constant) uniform GeometryBasePush {
    SsbcFrame frame;
    uint layer;               // the pyramid built
    uint geometric;           // 1: g_geometric.w holds geometric normals
    vec2 principal;           // the optical axis's image point minus the image's centre
                              // (pixels; non-zero for a jittered or off-centre projection)
} pc;

#include "ssbc_pyramid.glsl"
#include "ssbc_pyramid_write.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 3, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 4, rg32ui) uniform readonly uimage2D g_normal;
layout(set = 0, binding = 5, rg32ui) uniform readonly uimage2D g_albedo;
// Its w: the geometric normal where a normal map turned g_normal's
// (geometric_normal.glsl), if pc.geometric (a host's G-buffer has none).
layout(set = 0, binding = 6, rgba32f) uniform readonly image2D g_geometric;

// The surface's own normal at pixel q: the clusters' normal, their areas
// and creases come from it (a normal map shades, it does not bend the
// surface the positions lie on); g_normal's shading normal decides only
// how the pixel reflects.
vec3 surface_normal(ivec2 q) {
    vec3 shading = unpack_gbuffer_normal(imageLoad(g_normal, q)).xyz;
    return pc.geometric != 0u ? geometric_normal(imageLoad(g_geometric, q).w, shading) : shading;
}

// A convex polygon in image coordinates: the square clipped by at most
// eight lines, one vertex more per line.
const int MAX_VERTS = 12;

// Neighbours whose normals differ by less (cosine above this) are one flat
// surface: no crease between them. 0.95 (18 degrees) keeps curved
// surfaces seen at fine pitches out of the polygon code.
const float CREASE_COS = 0.95;
struct Polygon {
    vec2 v[MAX_VERTS];
    int n;
};

// The unnormalised ray through image point uv (pixel x spans [x, x + 1];
// the optical axis at the image's centre plus pc.principal) is
// r0 + u du + v dv.
struct ImageRays {
    vec3 r0;
    vec3 du;
    vec3 dv;
};

ImageRays image_rays() {
    vec3 f = pc.frame.camera_forward.xyz;
    vec3 up = pc.frame.camera_up.xyz;
    float s = pc.frame.camera_position.w;
    vec3 du = normalize(cross(f, up)) * s;
    vec3 dv = -up * s;
    vec2 axis = 0.5 * vec2(pc.frame.size) + pc.principal;
    return ImageRays(f - du * axis.x - dv * axis.y, du, dv);
}

vec3 image_ray(vec2 uv) {
    ImageRays r = image_rays();
    return r.r0 + r.du * uv.x + r.dv * uv.y;
}

// Where the ray through uv meets the plane (c, n); `hit` false if not in front.
vec3 on_plane(vec2 uv, vec3 c, vec3 n, out bool hit) {
    vec3 r = image_ray(uv);
    float t = dot(n, c - pc.frame.camera_position.xyz) / dot(n, r);
    hit = t > 0.0 && !isinf(t);
    return pc.frame.camera_position.xyz + r * t;
}

// Sutherland-Hodgman: the part of `a` where side(uv) = k.x + k.y u + k.z v >= 0.
Polygon clip(Polygon a, vec3 k) {
    Polygon out_poly;
    out_poly.n = 0;
    for (int i = 0; i < a.n; i++) {
        vec2 p = a.v[i];
        vec2 q = a.v[i + 1 < a.n ? i + 1 : 0];
        float sp = k.x + dot(k.yz, p);
        float sq = k.x + dot(k.yz, q);
        if (sp >= 0.0 && out_poly.n < MAX_VERTS) out_poly.v[out_poly.n++] = p;
        if ((sp >= 0.0) != (sq >= 0.0) && out_poly.n < MAX_VERTS) out_poly.v[out_poly.n++] = p + (q - p) * (sp / (sp - sq));
    }
    return out_poly;
}

// The polygon lifted onto the plane (c, n): its area, its centroid (`middle`) and its
// size (largest distance of a vertex from the centroid); false if a vertex
// is not in front of the camera or the polygon is degenerate.
bool lift(Polygon a, vec3 c, vec3 n, out float area, out vec3 middle, out float size) {
    area = 0.0;
    middle = vec3(0.0);
    size = 0.0;
    if (a.n < 3) return false;
    vec3 v[MAX_VERTS];
    bool ok = true;
    for (int i = 0; i < a.n; i++) {
        bool hit;
        v[i] = on_plane(a.v[i], c, n, hit);
        ok = ok && hit;
    }
    if (!ok) return false;
    vec3 cross_sum = vec3(0.0);
    float weight = 0.0;
    for (int i = 1; i + 1 < a.n; i++) {
        vec3 t = cross(v[i] - v[0], v[i + 1] - v[0]);
        cross_sum += t;
        middle += (v[0] + v[i] + v[i + 1]) * (length(t) / 3.0);
        weight += length(t);
    }
    if (!(weight > 0.0)) return false;
    middle /= weight;
    for (int i = 0; i < a.n; i++) size = max(size, length(v[i] - middle));
    area = 0.5 * length(cross_sum);
    return true;
}

// The pixel's square lifted onto the plane (c, n), when no crease cuts it:
// the planar quad's area from its diagonals, and its size from the
// corners' mean; false if a corner is not in front of the camera.
bool lift_square(vec2 corner, vec3 c, vec3 n, out float area, out float size) {
    bool h0, h1, h2, h3;
    vec3 v0 = on_plane(corner, c, n, h0);
    vec3 v1 = on_plane(corner + vec2(1.0, 0.0), c, n, h1);
    vec3 v2 = on_plane(corner + vec2(1.0, 1.0), c, n, h2);
    vec3 v3 = on_plane(corner + vec2(0.0, 1.0), c, n, h3);
    area = 0.5 * length(cross(v2 - v0, v3 - v1));
    vec3 mean = 0.25 * (v0 + v1 + v2 + v3);
    size = max(max(length(v0 - mean), length(v1 - mean)), max(length(v2 - mean), length(v3 - mean)));
    return h0 && h1 && h2 && h3;
}

// Whether a neighbour's normal differs enough for a crease (cheap test
// first: most pixels have none, and lavapipe runs the polygon code only
// for SIMD groups where one does).
bool any_crease_normal(ivec2 p, vec3 np) {
    ivec2 size = ivec2(layer_image_size(0u));
    bool any_found = false;
    for (int k = 0; k < 8; k++) {
        ivec2 q = clamp(p + CREASE_NEIGHBOURS[k], ivec2(0), size - 1);
        any_found = any_found || dot(np, surface_normal(q)) <= CREASE_COS;
    }
    return any_found;
}

// Whether the crease line (fp at p's centre, fq at the neighbour's) runs
// between the centres; `offset` to take from the line (p's centre snapped
// onto it) and the `side` sign that makes p's side positive. p's centre
// sees p's plane, so it is never truly beyond the line: within 1e-4 of the
// change between the centres it is on it (rounding put it either side:
// NVIDIA fuses multiply-adds, lavapipe and the CPU do not), and the line
// halves p's square. crease_side in src/cpu/ssbc.rs is the same.
bool crease_side(float fp, float fq, out float offset, out float side) {
    offset = abs(fp) <= 1e-4 * abs(fp - fq) ? fp : 0.0;
    fp -= offset;
    side = fp != 0.0 ? sign(fp) : -sign(fq);
    return fq != 0.0 && (fp == 0.0 || (fp > 0.0) != (fq > 0.0));
}

// Pixel p's footprint (see the top): its own area, and the largest part
// beyond a crease (back cluster, its area, neighbour code k + 1; 0: none).
// A side and a diagonal neighbour on one plane cut the same part: the first
// (a side neighbour) keeps it unless another is clearly (0.1%) larger, so
// that rounding does not pick whose radiance it carries.
void footprint(ivec2 p, vec3 cp, vec3 np, float ap, out float own_area, out GeoCluster back,
               out float back_area, out uint code) {
    vec3 eye = pc.frame.camera_position.xyz;
    Polygon square;
    square.n = 4;
    square.v[0] = vec2(p);
    square.v[1] = vec2(p) + vec2(1.0, 0.0);
    square.v[2] = vec2(p) + vec2(1.0, 1.0);
    square.v[3] = vec2(p) + vec2(0.0, 1.0);
    Polygon own = square;
    bool cut = false;  // by a crease line
    back = empty_cluster();
    back_area = 0.0;
    code = 0u;
    vec2 centre_p = vec2(p) + 0.5;
    ivec2 size = ivec2(layer_image_size(0u));
    for (int k = 0; k < 8; k++) {
        ivec2 q = p + CREASE_NEIGHBOURS[k];
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        vec4 position_q = imageLoad(g_position, q);
        if (position_q.w == 0.0) continue;
        vec3 cq = position_q.xyz;
        vec3 nq = surface_normal(q);
        float aq = pixel_area(cq, nq);
        if (dot(np, nq) > CREASE_COS || length(cq - cp) > 3.0 * (sqrt(ap) + sqrt(aq))) continue;
        // Zero where both planes are at the same depth: k_p (n_q . r) - k_q (n_p . r),
        // affine in uv as r is.
        float kp = dot(np, cp - eye);
        float kq = dot(nq, cq - eye);
        ImageRays r = image_rays();
        vec3 line = vec3(kp * dot(nq, r.r0) - kq * dot(np, r.r0), kp * dot(nq, r.du) - kq * dot(np, r.du),
                         kp * dot(nq, r.dv) - kq * dot(np, r.dv));
        vec2 centre_q = vec2(q) + 0.5;
        float fp = line.x + dot(line.yz, centre_p);
        float fq = line.x + dot(line.yz, centre_q);
        float offset, side;
        if (!crease_side(fp, fq, offset, side)) continue;
        fp -= offset;
        line.x -= offset;
        bool hit;
        vec3 crease = on_plane(centre_p + (centre_q - centre_p) * (fp / (fp - fq)), cp, np, hit);
        if (!hit || length(crease - cp) > 2.0 * length(cq - cp)) continue;
        line *= side;
        own = clip(own, line);
        cut = true;
        float area, extent;
        vec3 middle;
        if (lift(clip(square, -line), cq, nq, area, middle, extent) && extent <= 20.0 * sqrt(aq)
            && area > 1.001 * back_area) {
            back = make_cluster(middle, 0.0, 0.0, nq, 1.0, 1.0);
            back_area = area;
            code = uint(k) + 1u;
        }
    }
    float extent;
    vec3 middle;
    bool lifted = !cut ? lift_square(vec2(p), cp, np, own_area, extent)
        : lift(own, cp, np, own_area, middle, extent);
    // A plane seen nearly edge-on lifts the square far away: keep the
    // clamped area (min_cos_view) and no crease.
    if (!lifted || extent > 20.0 * sqrt(ap)) {
        own_area = ap;
        back = empty_cluster();
        back_area = 0.0;
        code = 0u;
    }
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, level_size(pc.layer, 0)))) return;
    uint dst = texel_index(pc.layer, p, 0);
    vec4 position = vec4(0.0);
    vec3 n = vec3(0.0);
    if (all(lessThan(uvec2(p), layer_image_size(pc.layer)))) {
        position = imageLoad(g_position, p);
        n = surface_normal(p);
    }
    bool geometry = position.w != 0.0;
    // A half-resolution layer-1 pixel is 2 x 2 image pixels (and a point:
    // footprints are for full-resolution layers).
    uint shift = layer_shift(pc.layer);
    float area = pixel_area(position.xyz, n) * float(1u << (2u * shift));
    GeoCluster back = empty_cluster();
    float back_area = 0.0;
    uint code = 0u;
    if (geometry && shift == 0u) {
        if (any_crease_normal(p, n)) {
            footprint(p, position.xyz, n, area, area, back, back_area, code);
        } else {
            float own_area, extent;
            if (lift_square(vec2(p), position.xyz, n, own_area, extent) && extent <= 20.0 * sqrt(area)) area = own_area;
        }
    }
    // Layer 0's glossy receivers, for the evaluation points (ssbc_eval.glsl).
    bool glossy = false;
    if (geometry && pc.layer == 0u && (pc.frame.layers & GLOSSY_RECEIVERS) != 0u) {
        vec4 shading = unpack_gbuffer_normal(imageLoad(g_normal, p));
        Brdf b = receiver_brdf(unpack_gbuffer_albedo(imageLoad(g_albedo, p)), shading);
        vec3 wo = normalize(pc.frame.camera_position.xyz - position.xyz);
        glossy = !brdf_is_lambertian(b) && !nearly_lambertian(b, shading.xyz, wo);
    }
    uint flags = (geometry ? 1u : 0u) | (code << 1) | (glossy ? GLOSSY_RECEIVER : 0u);
    // The back cluster lies on neighbour q's plane: its position (the
    // G-buffer's) and its normal as stored (ssbc_types.glsl, "Level 0").
    vec3 cq = vec3(0.0);
    vec3 nq = vec3(0.0);
    if (code > 0u) {
        ivec2 q = p + CREASE_NEIGHBOURS[code - 1u];
        cq = imageLoad(g_position, q).xyz;
        nq = level0_normal(uvec4(pack_level0_normal(surface_normal(q)), 0u, 0u, 0u));
    }
    store_level0(dst, pack_level0(position.xyz, n, geometry ? area : 0.0, flags, back.position_extent.xyz, cq, nq, back_area));
}
