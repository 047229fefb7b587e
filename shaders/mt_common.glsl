// Shared by the marching-tetrahedra passes (mt_*.comp), after mc_common.glsl and mc_sign_words.glsl.
//
// Each cell is split into six tetrahedra along its main diagonal (isoscope.cpu.tetra says
// why), so a grid point owns seven kinds of edges: kind q runs from the point to the point plus
// kind_dir(q), a 0/1 vector whose bit a is its step along axis a: the axes 0, 1, 2, the face
// diagonals (0, 1), (0, 2), (1, 2), then the body diagonal.  The table (mc_case_table.glsl's
// layout and image) names a triangle's vertices by 6-bit codes, not edges: the owning cell corner
// (bits 0-2, as isoscope.core.case_table numbers corners) | kind << 3.
//
// Per word, the counts image (rgba32ui) holds: x = where kinds 1-4 start among the word's own
// vertices (8 bits each), y = where kinds 5 and 6 start and the word's vertex total (8 bits each),
// z = the triangles of the word's cells, w = the brick-local index (see brick_word()) of the word
// that mt_triangles.comp's invocation at this word's place handles (mt_word_offsets.comp says why).
#include "mc_case_table.glsl"

uint triangle_codes(uint cube_case, uint t) { return case_table_word(cube_case * MAX_TRIANGLES_PER_CELL + t); }

const uint KINDS = 7u;
uint kind_dir(uint kind) { return (0x7653421u >> (4u * kind)) & 7u; }

uint kind_start(uint starts_x, uint starts_y, uint kind) {
    return kind == 0u ? 0u : kind < 5u ? (starts_x >> (8u * (kind - 1u))) & 255u
                                       : (starts_y >> (8u * (kind - 5u))) & 255u;
}
uint mt_vertex_total(uvec4 counts) { return (counts.y >> 16) & 255u; }
uint mt_work(uvec4 counts) { return mt_vertex_total(counts) + counts.z; }  // mt_triangles.comp's loop iterations

// The sign rows around a row of cells as cell_rows() gives them, with the rows past the grid's
// last row along axis 0 or 1 zero (their edges are masked off by kind_crossings).
CellRows border_rows(int i, int j, int w) {
    if (has_cells(i, j)) return cell_rows(i, j, w);
    CellRows rows;
    rows.at_k = uvec4(row_word(i, j, w), 0u, 0u, 0u);
    if (i + 1 < u_dims.x) rows.at_k.y = row_word(i + 1, j, w);
    if (j + 1 < u_dims.y) rows.at_k.z = row_word(i, j + 1, w);
    rows.at_k1 = uvec4(next_samples(i, j, w, rows.at_k.x), 0u, 0u, 0u);
    if (i + 1 < u_dims.x) rows.at_k1.y = next_samples(i + 1, j, w, rows.at_k.y);
    if (j + 1 < u_dims.y) rows.at_k1.z = next_samples(i, j + 1, w, rows.at_k.z);
    return rows;
}

// Bits k whose sample in sign row `row` (d0 | d1 << 1) and the one kind_dir(kind) further differ.
// Bits past the grid are not masked: callers count only bits below an existing vertex's, or mask.
uint kind_crossing(CellRows rows, uint row, uint kind) {
    uint dir = kind_dir(kind);
    uint there = row | (dir & 3u);
    return pick(rows.at_k, row) ^ ((dir & 4u) != 0u ? pick(rows.at_k1, there) : pick(rows.at_k, there));
}

// The edges of kind `kind` that word (i, j, w), the rows' corner 0, owns: those whose far end is in the grid.
uint owned_crossings(CellRows rows, ivec3 word, uint kind) {
    uint dir = kind_dir(kind);
    bool exists = ((dir & 1u) == 0u || word.x + 1 < u_dims.x) && ((dir & 2u) == 0u || word.y + 1 < u_dims.y);
    uint valid = (dir & 4u) != 0u ? axis2_edge_bits(word.z) : point_bits(word.z);
    return exists ? kind_crossing(rows, 0u, kind) & valid : 0u;
}
