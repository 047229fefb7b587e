#version 430
// Samples one user expression (EXPR_BODY: the statements app/volumes/expression.py's
// to_glsl emits from the whitelist grammar, ending in a return) on a regular grid, one
// slab of axis-0 planes per dispatch so a buffer never exceeds GL_MAX_SHADER_STORAGE_BLOCK_SIZE.
// Invocation x -> axis 2 (fastest in memory), y -> axis 1, z -> axis-0 plane of the slab.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(std430, binding = BLOCK_EXPR_SAMPLES) writeonly buffer Samples { float samples[]; };
// The very float32 values the numpy back end uses: first the formula's EXPR_NUMBERS
// numbers (read from here, not written as literals, so the compiler cannot fold 0*v to 0),
// then the sample coordinates: axis 0's u_shape.x values, then axis 1's, then axis 2's
// (lo + index * step computed here would round differently, and log(x) at x = 0 or
// 1e-17 is -Inf or finite).
layout(std430, binding = BLOCK_EXPR_INPUTS) readonly buffer Inputs { float inputs[]; };

uniform uvec3 u_shape;     // the whole grid: samples along axes 0, 1, 2
uniform uint u_first;      // axis-0 index of this slab's first plane
uniform uint u_planes;     // planes in this slab

#include "expr_functions.glsl"

float field(float x, float y, float z) {
    EXPR_BODY
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (id.x >= u_shape.z || id.y >= u_shape.y || id.z >= u_planes) return;
    uint i = u_first + id.z;
    float x = inputs[EXPR_NUMBERS + i];
    float y = inputs[EXPR_NUMBERS + u_shape.x + id.y];
    float z = inputs[EXPR_NUMBERS + u_shape.x + u_shape.y + id.x];
    samples[(id.z * u_shape.y + id.y) * u_shape.z + id.x] = field(x, y, z);
}
