// Shadow-map lookup shared by the lighting passes. Expects `lights`,
// `shadow_views` and `shadow_maps` to be declared by the including shader.
#ifndef SSBC_SHADOW_GLSL
#define SSBC_SHADOW_GLSL

#include "brdf.glsl"

// Cube face of a direction, in the order +X, -X, +Y, -Y, +Z, -Z.
int cube_face(vec3 d) {
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0 : 1;
    if (a.y >= a.z) return d.y > 0.0 ? 2 : 3;
    return d.z > 0.0 ? 4 : 5;
}

float linear_depth(float z, vec4 params) {
    if (params.z > 0.5) return params.x + z * (params.y - params.x);
    return params.x * params.y / (params.y - z * (params.y - params.x));
}

// Fraction of a 3x3 neighbourhood of shadow texels that sees point p on a
// surface of normal n (the geometric one: the offset lifts p off the
// surface the shadow map stored; a normal map's normal, tilted towards the
// light, lifted it too little and the plane shadowed itself in stripes).
float shadow_visibility(GpuLight light, vec3 p, vec3 n) {
    int layer = light.shadow.x;
    if (light.shadow.y == 6) {
        layer += cube_face(p - light.position_kind.xyz);
    }
    ShadowView view = shadow_views[layer];
    vec4 probe = view.view_proj * vec4(p, 1.0);
    float receiver = linear_depth(probe.z / probe.w, view.params);
    // Texel footprint at the receiver: grows with distance for perspective maps.
    float texel = view.params.z > 0.5 ? view.params.w : view.params.w * receiver;
    // Normal offset by 1.5 texels avoids acne on slopes; a small depth bias the rest.
    vec4 clip = view.view_proj * vec4(p + n * (1.5 * texel), 1.0);
    vec3 ndc = clip.xyz / clip.w;
    float depth = linear_depth(ndc.z, view.params);
    vec2 uv = ndc.xy * 0.5 + 0.5;
    vec2 size = vec2(textureSize(shadow_maps, 0).xy);
    float lit = 0.0;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            vec2 tap = clamp(uv + vec2(dx, dy) / size, vec2(0.5) / size, vec2(1.0) - vec2(0.5) / size);
            float stored = linear_depth(textureLod(shadow_maps, vec3(tap, float(layer)), 0.0).r, view.params);
            lit += (depth <= stored + 2.0 * texel) ? 1.0 : 0.0;
        }
    }
    return lit / 9.0;
}

// The irradiance `light` gives at p (shading normal n, on a surface of
// normal `surface`), shadowed, and the unit direction towards it (wi);
// zero if it does not reach p.
vec3 light_irradiance(GpuLight light, vec3 p, vec3 n, vec3 surface, out vec3 wi) {
    uint kind = uint(light.position_kind.w);
    vec3 e;
    if (kind == LIGHT_DIRECTIONAL) {
        wi = -light.direction_cos_outer.xyz;
        e = light.intensity_cos_inner.rgb;
    } else {
        vec3 to_light = light.position_kind.xyz - p;
        float d2 = dot(to_light, to_light);
        wi = to_light * inversesqrt(d2);
        e = light.intensity_cos_inner.rgb / d2;
        if (kind == LIGHT_SPOT) {
            float cos_outer = light.direction_cos_outer.w;
            float cos_inner = light.intensity_cos_inner.w;
            float cd = dot(-wi, light.direction_cos_outer.xyz);
            float t = clamp((cd - cos_outer) / max(cos_inner - cos_outer, 1e-3), 0.0, 1.0);
            e *= t * t;
        }
    }
    float cos_theta = dot(n, wi);
    if (cos_theta <= 0.0 || max(e.r, max(e.g, e.b)) <= 0.0) return vec3(0.0);
    return e * cos_theta * shadow_visibility(light, p, surface);
}

#endif
