#version 460
// Shadow map: depth, one layer per draw; uv, material and vertex colour for
// alpha masks.
// Vertices reach world space by their object's transform.
#include "objects.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in uint in_material;
layout(location = 5) in vec4 in_color;

layout(push_constant) uniform Push {
    mat4 view_proj;
    uint object;           // the object drawn
} pc;

layout(location = 0) out vec2 v_uv;
layout(location = 1) flat out uint v_material;
layout(location = 2) out vec4 v_color;

void main() {
    GpuObject object = objects[pc.object];
    v_uv = in_uv;
    v_color = in_color;
    v_material = object_material(object, in_material);
    gl_Position = pc.view_proj * (object.model * vec4(in_position, 1.0));
}
