#version 430
// Pass 7, over active bricks, one invocation per word: name each vertex the word owns, in
// the vertex's own slot (word id, axis << 5 | bit), so that mc_vertices.comp can give every
// vertex its own invocation: words own 0 to 96 vertices, and one invocation per word would
// leave most SIMD lanes waiting on the busiest word.
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_active_bricks.glsl"

layout(std430, binding = 3) readonly buffer WordCounts { uint word_counts[]; };
layout(std430, binding = 5) readonly buffer WordOffsets { uvec2 word_offsets[]; };  // (vertex, triangle)
layout(std430, binding = 6) writeonly buffer VertexRecords { uvec4 vertex_records[]; };  // 2 per vertex

void main() {
    uint brick;
    if (!active_brick(brick)) return;
    bool exists;
    ivec3 word = brick_word(brick, exists);
    if (!exists) return;
    uint id = word_id_of(word.x, word.y, word.z);
    uint next = word_offsets[id].x;
    uvec3 crossing = crossing_masks(word.x, word.y, word.z);
    // One iteration per vertex, axis by axis, so lanes on different words stay in step.
    uint end = next + vertex_total(word_counts[id]);
    uint axis = 0u, bits = crossing.x;
    for (; next < end; ++next) {
        while (bits == 0u) {
            ++axis;
            bits = axis == 1u ? crossing.y : crossing.z;
        }
        uint b = uint(findLSB(bits));
        bits &= bits - 1u;
        vertex_records[2u * next] = uvec4(id, (axis << 5) | b, 0u, 0u);
    }
}
