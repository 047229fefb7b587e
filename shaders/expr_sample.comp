#version 430
// Samples one user expression (EXPR_FIELD, GLSL emitted by app/volumes/expression.py
// from the whitelist grammar) on a regular grid, one slab of axis-0 planes per
// dispatch so a buffer never exceeds GL_MAX_SHADER_STORAGE_BLOCK_SIZE.
// Invocation x -> axis 2 (fastest in memory), y -> axis 1, z -> axis-0 plane of the slab.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(std430, binding = 0) writeonly buffer Samples { float samples[]; };

uniform uvec3 u_shape;     // the whole grid: samples along axes 0, 1, 2
uniform uint u_first;      // axis-0 index of this slab's first plane
uniform uint u_planes;     // planes in this slab
uniform vec3 u_lo;         // coordinates of sample (0, 0, 0)
uniform vec3 u_step;       // distance between samples along each axis

#include "expr_functions.glsl"

float field(float x, float y, float z) {
    return EXPR_FIELD;
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (id.x >= u_shape.z || id.y >= u_shape.y || id.z >= u_planes) return;
    uint i = u_first + id.z;
    // lo + index * step, as app/volumes/grid.py places samples.
    float x = u_lo.x + float(i) * u_step.x;
    float y = u_lo.y + float(id.y) * u_step.y;
    float z = u_lo.z + float(id.x) * u_step.z;
    samples[(id.z * u_shape.y + id.y) * u_shape.z + id.x] = field(x, y, z);
}
