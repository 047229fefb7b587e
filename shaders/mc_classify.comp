#version 430
// Pass 3, over active bricks, one invocation per word: the vertices the word owns (per axis)
// and the triangles of its cells, packed into one uint for the passes that follow (with the word's
// own place in its brick, which mc_word_offsets.comp may reorder: see mc_common.glsl).
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_active_bricks.glsl"
#include "mc_case_table.glsl"

layout(r32ui, binding = UNIT_WORD_COUNTS) writeonly uniform uimage2D u_word_counts;

void main() {
    uint brick;
    if (!active_brick(brick)) return;
    bool exists;
    ivec3 word = brick_word(brick, exists);
    if (!exists) return;

    uvec3 crossing;
    uint triangles = 0u;
    if (has_cells(word.x, word.y)) {
        CellRows rows = cell_rows(word.x, word.y, word.z);
        crossing = crossing_from_rows(rows, word.z);
        uint cells = mixed_cells(rows, word.z);
        while (cells != 0u) {
            uint k = uint(findLSB(cells));
            cells &= cells - 1u;
            triangles += triangle_count(cell_case(rows, k));
        }
    } else {
        crossing = crossing_masks(word.x, word.y, word.z);  // the grid's last row along axis 0 or 1
    }
    uint counts = uint(bitCount(crossing.x)) | (uint(bitCount(crossing.y)) << 6)
                | (uint(bitCount(crossing.z)) << 12) | (triangles << 18) | (gl_LocalInvocationIndex << 26);
    imageStore(u_word_counts, word_texel(word_id_of(word.x, word.y, word.z)), uvec4(counts));
}
