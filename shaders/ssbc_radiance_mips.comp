#version 460
// SSBC radiance pyramid of the term being compensated, S_{k-1}. Mode 0 copies
// it into level 0; mode 1 builds level l as the area-weighted mean of level
// l-1 (weights from the geometry pyramid's area).

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D term;          // S_{k-1}, full resolution
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D src_area;      // geometry level l-1 (w = area)
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D src_radiance;  // level l-1
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D dst_radiance;

layout(push_constant) uniform Push {
    uvec2 dst_size;
    uvec2 term_size;
    uint mode;
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.dst_size))) return;
    if (pc.mode == 0u) {
        vec3 l = all(lessThan(uvec2(p), pc.term_size)) ? imageLoad(term, p).rgb : vec3(0.0);
        imageStore(dst_radiance, p, vec4(l, 1.0));
        return;
    }
    vec3 sum = vec3(0.0);
    float area = 0.0;
    for (int k = 0; k < 4; k++) {
        ivec2 c = p * 2 + ivec2(k & 1, k >> 1);
        float a = imageLoad(src_area, c).w;
        sum += a * imageLoad(src_radiance, c).rgb;
        area += a;
    }
    imageStore(dst_radiance, p, vec4(area > 0.0 ? sum / area : vec3(0.0), 1.0));
}
