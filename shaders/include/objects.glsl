// The scene's objects (GpuObject in common.glsl): vertex shaders read the
// drawn object's index from their push block (set per draw).
#ifndef SSBC_OBJECTS_GLSL
#define SSBC_OBJECTS_GLSL
#include "common.glsl"

layout(set = 0, binding = 8) readonly buffer Objects { GpuObject objects[]; };

// The material a vertex of `object` is drawn with: its override or the mesh's.
uint object_material(GpuObject object, uint mesh_material) {
    return object.params.x == 0xFFFFFFFFu ? mesh_material : object.params.x;
}

#endif
