#version 430
// Once per volume, step 1 of 2: the value range of each word's row segment, samples
// 32w .. 32w+32 (one more than the word: its cells and axis-2 edges reach it).
layout(local_size_x = 64) in;
#include "mc_common.glsl"

uniform uint u_word_count;
layout(std430, binding = 8) writeonly buffer RowRanges { vec2 row_ranges[]; };

void main() {
    uint id = linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
    if (id >= u_word_count) return;
    int w = int(id % uint(u_words));
    uint row = id / uint(u_words);
    ivec2 ij = ivec2(int(row / uint(u_dims.y)), int(row % uint(u_dims.y)));
    vec2 range = vec2(1.0 / 0.0, -1.0 / 0.0);
    int last = min(32 * w + 32, u_dims.z - 1);
    for (int q = 8 * w; 4 * q <= last; ++q) {  // 4 samples per load; those past `last` are skipped
        vec4 v = quad_at(ij.x, ij.y, q);
        bvec4 wanted = lessThanEqual(ivec4(4 * q) + ivec4(0, 1, 2, 3), ivec4(last));
        vec4 lo = mix(vec4(1.0 / 0.0), v, wanted), hi = mix(vec4(-1.0 / 0.0), v, wanted);
        range = vec2(min(range.x, min(min(lo.x, lo.y), min(lo.z, lo.w))),
                     max(range.y, max(max(hi.x, hi.y), max(hi.z, hi.w))));
    }
    row_ranges[id] = range;
}
