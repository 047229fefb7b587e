#version 430
// Pass 2, over active bricks, one invocation per word: pack the inside bit of each of its
// WORD_BITS samples along axis 2.  Ties count as inside (a symbolic perturbation: a sample equal
// to the level is taken as just above it), so no later pass needs a special case.
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"
#include "mc_active_bricks.glsl"

layout(r32ui, binding = UNIT_SIGN_WORDS) writeonly uniform uimage2D u_sign_words;

void main() {
    uint brick;
    ivec3 word;
    if (!active_word(brick, word)) return;
    uint bits = 0u;
    for (int q = 0; q < QUADS_PER_WORD; ++q) {  // SAMPLES_PER_TEXEL (4) samples per load
        bvec4 inside = greaterThanEqual(u_sign * quad_at(word.x, word.y, QUADS_PER_WORD * word.z + q), vec4(u_level));
        bits |= (uint(inside.x) | uint(inside.y) << 1 | uint(inside.z) << 2 | uint(inside.w) << 3)
                << uint(SAMPLES_PER_TEXEL * q);
    }
    imageStore(u_sign_words, word_texel(word_id_of(word.x, word.y, word.z)), uvec4(bits & point_bits(word.z)));
}
