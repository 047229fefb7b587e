#version 430
// Pass 2, over active bricks, one invocation per word: pack the inside bit of each of its
// 32 samples along axis 2.  Ties count as inside: the seed's perturbation of exact zeros,
// done symbolically, so no later pass needs a special case.
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"
#include "mc_active_bricks.glsl"

layout(std430, binding = 0) writeonly buffer SignWords { uint sign_words[]; };

void main() {
    uint brick;
    if (!active_brick(brick)) return;
    bool exists;
    ivec3 word = brick_word(brick, exists);
    if (!exists) return;
    int count = min(32, u_dims.z - 32 * word.z);
    uint bits = 0u;
    for (int b = 0; b < count; ++b) {
        bits |= uint(field_at(ivec3(word.x, word.y, 32 * word.z + b)) >= u_level) << uint(b);
    }
    sign_words[word_id_of(word.x, word.y, word.z)] = bits;
}
