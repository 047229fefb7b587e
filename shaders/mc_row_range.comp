#version 430
// Once per volume, step 1 of 2: the value range of each word's row segment, samples
// 32w .. 32w+32 (one more than the word: its cells and axis-2 edges reach it).
// A fixed number of texel loads per word (the row's last texels clamped to the one holding its
// last sample, whose samples past it are masked), with the minima and maxima kept per component
// and folded once at the end: the loop that stopped at each word's own end and folded every
// texel took 9.6 ms on a 256^3 float32 volume.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_common.glsl"

uniform uint u_word_count;
layout(std430, binding = BLOCK_ROW_RANGES) writeonly buffer RowRanges { vec2 row_ranges[]; };
// Set where a sample is NaN or infinite: a volume whose values nothing else scanned
// (app/gpu/resident.py's value range; the ranges are then meaningless).
layout(std430, binding = BLOCK_NON_FINITE) buffer NonFinite { uint non_finite; };

void main() {
    uint id = linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
    if (id >= u_word_count) return;
    ivec3 word = word_of_id(id);
    int last = min(WORD_BITS * (word.z + 1), u_dims.z - 1);
    int last_quad = last / SAMPLES_PER_TEXEL;
    vec4 lo = vec4(1.0 / 0.0), hi = vec4(-1.0 / 0.0);
    bvec4 bad = bvec4(false);
    for (int t = 0; t <= QUADS_PER_WORD; ++t) {  // the word's texels, then the next word's first
        int q = min(QUADS_PER_WORD * word.z + t, last_quad);
        vec4 v = quad_at(word.x, word.y, q);
        bad = bvec4(uvec4(bad) | uvec4(isnan(v)) | uvec4(isinf(v)));  // padding past the row is 0
        bvec4 wanted = lessThanEqual(ivec4(SAMPLES_PER_TEXEL * q) + ivec4(0, 1, 2, 3), ivec4(last));
        lo = min(lo, mix(vec4(1.0 / 0.0), v, wanted));
        hi = max(hi, mix(vec4(-1.0 / 0.0), v, wanted));
    }
    if (any(bad)) non_finite = 1u;
    row_ranges[id] = vec2(min(min(lo.x, lo.y), min(lo.z, lo.w)), max(max(hi.x, hi.y), max(hi.z, hi.w)));
}
