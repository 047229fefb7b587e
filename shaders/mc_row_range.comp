#version 430
// Once per volume, step 1 of 2: the value range of each word's row segment, samples
// 32w .. 32w+32 (one more than the word: its cells and axis-2 edges reach it).
layout(local_size_x = GROUP_SIZE) in;
#include "mc_common.glsl"

uniform uint u_word_count;
layout(std430, binding = 8) writeonly buffer RowRanges { vec2 row_ranges[]; };

void main() {
    uint id = linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
    if (id >= u_word_count) return;
    ivec3 word = word_of_id(id);
    vec2 range = vec2(1.0 / 0.0, -1.0 / 0.0);
    int last = min(WORD_BITS * (word.z + 1), u_dims.z - 1);
    for (int q = QUADS_PER_WORD * word.z; SAMPLES_PER_TEXEL * q <= last; ++q) {  // those past `last` are skipped
        vec4 v = quad_at(word.x, word.y, q);
        bvec4 wanted = lessThanEqual(ivec4(SAMPLES_PER_TEXEL * q) + ivec4(0, 1, 2, 3), ivec4(last));
        vec4 lo = mix(vec4(1.0 / 0.0), v, wanted), hi = mix(vec4(-1.0 / 0.0), v, wanted);
        range = vec2(min(range.x, min(min(lo.x, lo.y), min(lo.z, lo.w))),
                     max(range.y, max(max(hi.x, hi.y), max(hi.z, hi.w))));
    }
    row_ranges[id] = range;
}
