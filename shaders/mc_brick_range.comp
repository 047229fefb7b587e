#version 430
// Once per volume: each brick's value range over every sample its words' edges and cells
// touch (its rows, one more row along axes 0 and 1, one more sample along axis 2).
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"

layout(std430, binding = 8) writeonly buffer BrickRanges { vec2 brick_ranges[]; };

shared vec2 partial[BRICK_WORDS];

vec2 row_range(int i, int j, int w) {
    vec2 r = vec2(1.0 / 0.0, -1.0 / 0.0);
    if (i >= u_dims.x || j >= u_dims.y) return r;
    int last = min(32 * w + 32, u_dims.z - 1);
    for (int k = 32 * w; k <= last; ++k) {
        float v = sample_at(ivec3(i, j, k));
        r = vec2(min(r.x, v), max(r.y, v));
    }
    return r;
}

void main() {
    uint brick = linear_group();
    if (brick >= u_brick_count) return;
    bool exists;
    ivec3 word = brick_word(brick, exists);
    vec2 r = row_range(word.x, word.y, word.z);
    // The halo rows (i = brick end along axis 0, or j = brick end along axis 1), shared out.
    int lid = int(gl_LocalInvocationIndex);
    int i0 = word.x - lid / BRICK_J, j0 = word.y - lid % BRICK_J;
    if (lid <= BRICK_J) {
        vec2 h = row_range(i0 + BRICK_I, j0 + lid, word.z);
        r = vec2(min(r.x, h.x), max(r.y, h.y));
    } else if (lid <= BRICK_J + BRICK_I) {
        vec2 h = row_range(i0 + lid - BRICK_J - 1, j0 + BRICK_J, word.z);
        r = vec2(min(r.x, h.x), max(r.y, h.y));
    }
    partial[lid] = r;
    barrier();
    for (int stride = BRICK_WORDS / 2; stride > 0; stride >>= 1) {
        if (lid < stride) partial[lid] = vec2(min(partial[lid].x, partial[lid + stride].x),
                                              max(partial[lid].y, partial[lid + stride].y));
        barrier();
    }
    if (lid == 0) brick_ranges[brick] = partial[0];
}
