#version 430
// Pass 1: pack the inside bit of every sample, 32 per word along axis 2.
// One texture load per sample; every later pass works on these bits.
layout(local_size_x = 64) in;
#include "mc_common.glsl"

layout(std430, binding = 0) writeonly buffer SignWords { uint sign_words[]; };

void main() {
    uint word_id = invocation_index();
    if (word_id >= u_word_count) return;
    ivec3 p = word_origin(word_id);
    int count = min(32, u_dims.z - p.z);
    uint bits = 0u;
    for (int b = 0; b < count; ++b) {
        // Ties count as inside: the seed's perturbation of exact zeros, done symbolically.
        bits |= uint(field_at(ivec3(p.x, p.y, p.z + b)) >= u_level) << uint(b);
    }
    sign_words[word_id] = bits;
}
