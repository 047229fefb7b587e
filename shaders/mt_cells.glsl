// The tetrahedra's cell kind, for passes 3-7 (cells_*.glsl): its edges, its per-word counts and
// the functions those passes read them through (mc_cells.glsl gives the same for the cubes).
//
// Each cell is split into six tetrahedra along its main diagonal (isoscope.cpu.tetra says
// why), so a grid point owns seven kinds of edges: kind q runs from the point to the point plus
// kind_dir(q), a 0/1 vector whose bit a is its step along axis a: the axes 0, 1, 2, the face
// diagonals (0, 1), (0, 2), (1, 2), then the body diagonal.  The table (mc_case_table.glsl's
// layout and image) names a triangle's vertices by 6-bit codes, not edges: the owning cell corner
// (bits 0-2, as isoscope.core.case_table numbers corners) | kind << 3.
//
// Per word, the counts image (WORD_COUNTS_FORMAT: rgba32ui here) holds: x = where kinds 1-4 start
// among the word's own vertices (8 bits each), y = where kinds 5 and 6 start and the word's vertex
// total (8 bits each), z = the triangles of the word's cells, w = the brick-local index (see
// brick_word()) of the word that pass 7's invocation at this word's place handles
// (cells_word_offsets.glsl says why).
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_case_table.glsl"

const uint KINDS = 7u;
uint kind_dir(uint kind) { return (0x7653421u >> (4u * kind)) & 7u; }

uint kind_start(uint starts_x, uint starts_y, uint kind) {
    return kind == 0u ? 0u : kind < 5u ? (starts_x >> (8u * (kind - 1u))) & 255u
                                       : (starts_y >> (8u * (kind - 5u))) & 255u;
}
uint counts_vertices(uvec4 counts) { return (counts.y >> 16) & 255u; }
uint counts_triangles(uvec4 counts) { return counts.z; }
uint counts_taken(uvec4 counts) { return counts.w; }
uvec4 counts_with_taken(uvec4 counts, uint local) { return uvec4(counts.xyz, local); }

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

// The counts of word `word` (the rows' corner 0) at place `place` of its brick, with `triangles`.
uvec4 word_counts(CellRows rows, ivec3 word, uint triangles, uint place) {
    uint starts_x = 0u, starts_y = 0u, total = 0u;
    for (uint kind = 0u; kind < KINDS; ++kind) {
        if (kind >= 1u && kind < 5u) starts_x |= total << (8u * (kind - 1u));
        if (kind >= 5u) starts_y |= total << (8u * (kind - 5u));
        total += uint(bitCount(owned_crossings(rows, word, kind)));
    }
    return uvec4(starts_x, starts_y | (total << 16), triangles, place);  // w: itself, until sorted
}

// The table entry of cell k of word `word` (its case: the cubes' table is by case), and what it adds to
// the word's triangle count (cells_classify.glsl).
uint cell_entry(CellRows rows, ivec3 word, uint k) { return cell_case(rows, k); }
uint cell_work(uint cube_case) { return triangle_count(cube_case); }
