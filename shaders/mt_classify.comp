#version 430
// Tetrahedra pass 3 (after mc_bricks and mc_signs), over active bricks, one invocation per word:
// where each edge kind's vertices start among the word's own, their total, and the triangles of
// its cells' tetrahedra (see mt_common.glsl for the packing).
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_active_bricks.glsl"
#include "mt_common.glsl"

layout(rgba32ui, binding = UNIT_WORD_COUNTS) writeonly uniform uimage2D u_word_counts;

void main() {
    uint brick;
    if (!active_brick(brick)) return;
    bool exists;
    ivec3 word = brick_word(brick, exists);
    if (!exists) return;

    CellRows rows = border_rows(word.x, word.y, word.z);
    uint starts_x = 0u, starts_y = 0u, total = 0u;
    for (uint kind = 0u; kind < KINDS; ++kind) {
        if (kind >= 1u && kind < 5u) starts_x |= total << (8u * (kind - 1u));
        if (kind >= 5u) starts_y |= total << (8u * (kind - 5u));
        total += uint(bitCount(owned_crossings(rows, word, kind)));
    }
    uint triangles = 0u;
    if (has_cells(word.x, word.y)) {
        uint cells = mixed_cells(rows, word.z);
        while (cells != 0u) {
            uint k = uint(findLSB(cells));
            cells &= cells - 1u;
            triangles += triangle_count(cell_case(rows, k));
        }
    }
    imageStore(u_word_counts, word_texel(word_id_of(word.x, word.y, word.z)),
               uvec4(starts_x, starts_y | (total << 16), triangles, gl_LocalInvocationIndex));  // w: itself, until sorted
}
