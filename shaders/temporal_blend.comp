#version 460
// Temporal history, step 2: this frame's indirect light (the final image
// minus the direct light) added to the reprojected history as a running
// mean of at most pc.max_frames frames, and the image made of the direct
// light and that mean. When lights changed (pc.lights_changed), history is
// kept where the indirect light changed little: the relative change of the
// 5x5 neighbourhood's mean (which holds a whole interleaved pattern, so the
// VPL subsets' noise averages out) lowers the frames kept linearly, to none
// at pc.light_change.

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D frame_final;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D frame_direct;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D reprojected;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D history;
layout(set = 0, binding = 4, rgba32f) uniform writeonly image2D temporal_final;

layout(push_constant) uniform Push {
    uvec2 size;
    float max_frames;     // frames the mean may average this frame
    uint lights_changed;  // 1: weigh history by the local change
    float light_change;   // relative change that drops history
} pc;

const int RADIUS = 2;

float luminance(vec3 c) {
    return dot(c, vec3(0.2126, 0.7152, 0.0722));
}

vec3 frame_indirect(ivec2 q) {
    return imageLoad(frame_final, q).rgb - imageLoad(frame_direct, q).rgb;
}

// Frames of history a pixel keeps when lights changed: the neighbourhood's
// mean indirect light now against the history's, where both exist.
float light_frames(ivec2 p) {
    float now = 0.0;
    float before = 0.0;
    for (int dy = -RADIUS; dy <= RADIUS; dy++) {
        for (int dx = -RADIUS; dx <= RADIUS; dx++) {
            ivec2 q = p + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(uvec2(q), pc.size))) continue;
            vec4 h = imageLoad(reprojected, q);
            if (h.a == 0.0) continue;
            now += luminance(frame_indirect(q));
            before += luminance(h.rgb);
        }
    }
    float change = abs(now - before) / max(max(now, before), 1e-30);
    float keep = clamp(1.0 - change / pc.light_change, 0.0, 1.0);
    return max(1.0, pc.max_frames * keep);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.size))) return;
    vec4 final_now = imageLoad(frame_final, p);
    if (final_now.a == 0.0) {
        imageStore(history, p, vec4(0.0));
        imageStore(temporal_final, p, final_now);
        return;
    }
    vec3 direct = imageLoad(frame_direct, p).rgb;
    vec3 indirect = final_now.rgb - direct;
    vec4 h = imageLoad(reprojected, p);
    float frames = 1.0;
    vec3 mean = indirect;
    if (h.a > 0.0) {
        float limit = pc.lights_changed == 1u ? light_frames(p) : pc.max_frames;
        frames = min(h.a + 1.0, limit);
        mean = h.rgb + (indirect - h.rgb) / frames;
    }
    imageStore(history, p, vec4(mean, frames));
    imageStore(temporal_final, p, vec4(direct + mean, final_now.a));
}
