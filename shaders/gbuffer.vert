#version 460
// G-buffer: transform world-space vertices by the camera.

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in uint in_material;
layout(location = 4) in vec4 in_tangent;

layout(push_constant) uniform Push {
    mat4 view_proj;
    vec4 camera_position;
} pc;

layout(location = 0) out vec3 v_position;
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec2 v_uv;
layout(location = 3) flat out uint v_material;
layout(location = 4) out vec4 v_tangent;

void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_uv = in_uv;
    v_material = in_material;
    v_tangent = in_tangent;
    gl_Position = pc.view_proj * vec4(in_position, 1.0);
}
