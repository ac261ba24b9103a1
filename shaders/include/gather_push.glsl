// The push block of the kernels that sum VPLs (`GatherPush` in Rust, one
// type for all of them).
layout(push_constant) uniform GatherPush {
    uvec2 size;
    uint count;           // VPLs, or N: the interleaved pattern is N x N subsets
    uint tile;            // ISM tile side
    uint tiles_per_row;
    float far;            // ISM distances are stored divided by this
    float bound;          // b [1/m^2]; +inf disables clamping
    float ism_bias;       // relative depth tolerance of the ISM test
    float point_radius;   // world radius of one splatted point
    vec4 camera_position; // xyz: the eye (glossy receivers reflect towards it); w: the
                          // scene's diagonal, at most 1 m (exact_lift)
} pc;
