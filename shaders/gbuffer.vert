#version 460
// G-buffer: an object's mesh vertices to world space (its transform), then
// by the camera.
#include "objects.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in uint in_material;
layout(location = 4) in vec4 in_tangent;
layout(location = 5) in vec4 in_color;

layout(push_constant) uniform Push {
    mat4 view_proj;
    vec4 camera_position;
    uint layer1_shift;     // (the fragment shaders')
    uint object;           // the object drawn
} pc;

layout(location = 0) out vec3 v_position;
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec2 v_uv;
layout(location = 3) flat out uint v_material;
layout(location = 4) out vec4 v_tangent;
layout(location = 5) out vec4 v_color;

void main() {
    GpuObject object = objects[pc.object];
    vec4 world = object.model * vec4(in_position, 1.0);
    v_position = world.xyz;
    vec3 n = mat3(object.normal_matrix) * in_normal;
    v_normal = dot(n, n) > 0.0 ? normalize(n) : n;
    v_uv = in_uv;
    v_color = in_color;
    v_material = object_material(object, in_material);
    // A mirroring transform flips the bitangent's handedness.
    vec3 t = mat3(object.model) * in_tangent.xyz;
    float handedness = uintBitsToFloat(object.params.z);
    v_tangent = in_tangent == vec4(0.0)
        ? vec4(0.0)
        : vec4(dot(t, t) > 0.0 ? normalize(t) : t, in_tangent.w < 0.0 ? -handedness : handedness);
    gl_Position = pc.view_proj * world;
}
