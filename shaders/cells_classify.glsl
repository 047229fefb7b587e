// Pass 3, over active bricks, one invocation per word: the vertices the word owns and the triangles
// of its cells, packed by the cell kind's word_counts() (mc_cells.glsl, mt_cells.glsl, included
// before this) with the word's own place in its brick, which pass 6 (cells_word_offsets.glsl) may
// reorder.
#include "mc_active_bricks.glsl"
layout(WORD_COUNTS_FORMAT, binding = UNIT_WORD_COUNTS) writeonly uniform uimage2D u_word_counts;

void main() {
    uint brick;
    ivec3 word;
    if (!active_word(brick, word)) return;

    CellRows rows = border_rows(word.x, word.y, word.z);
    uint work = 0u;  // the triangles (with the trilinear kind's own vertices: mc3_cells.glsl)
    if (has_cells(word.x, word.y)) {  // not the grid's last row along axis 0 or 1
        uint cells = mixed_cells(rows, word.z);
        while (cells != 0u) {
            uint k = uint(findLSB(cells));
            cells &= cells - 1u;
            work += cell_work(cell_entry(rows, word, k));
        }
    }
    imageStore(u_word_counts, word_texel(word_id_of(word.x, word.y, word.z)),
               word_counts(rows, word, work, gl_LocalInvocationIndex));
}
