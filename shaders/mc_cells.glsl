// The cubes' cell kind, for passes 3-7 (cells_*.glsl): the per-word counts, which those passes read
// and write only through the functions below (mt_cells.glsl gives the same for the tetrahedra).  The
// counts image is WORD_COUNTS_FORMAT (r32ui here: CellKind.count_components); each function takes
// its texel as imageLoad gives it.
//
// Per word, one uint: the vertices it owns along axes 0, 1, 2 (6 bits each), the triangles of its
// cells (8 bits: at most 32 cells x MAX_TRIANGLES_PER_CELL, checked in isoscope.gpu.cubes), and in
// the top 6 bits the brick-local index of the word that pass 7's invocation at this word's place
// takes (cells_word_offsets.glsl orders them; cells_classify.glsl writes each word its own place).
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_case_table.glsl"

uint vertices_along(uint counts, uint axis) { return (counts >> (6u * axis)) & 63u; }
uint counts_vertices(uvec4 counts) {
    return vertices_along(counts.x, 0u) + vertices_along(counts.x, 1u) + vertices_along(counts.x, 2u);
}
uint counts_triangles(uvec4 counts) { return (counts.x >> 18) & 255u; }
uint counts_taken(uvec4 counts) { return counts.x >> 26; }
uvec4 counts_with_taken(uvec4 counts, uint local) { return uvec4((counts.x & 0x03FFFFFFu) | (local << 26)); }

// The counts of word `word` (the rows' corner 0) at place `place` of its brick, with `triangles`.
uvec4 word_counts(CellRows rows, ivec3 word, uint triangles, uint place) {
    uvec3 crossing = owned_axis_crossings(rows, word);
    return uvec4(uint(bitCount(crossing.x)) | (uint(bitCount(crossing.y)) << 6)
                 | (uint(bitCount(crossing.z)) << 12) | (triangles << 18) | (place << 26));
}

// The table entry of cell k of word `word` (its case: the cubes' table is by case), and what it adds to
// the word's triangle count (cells_classify.glsl).
uint cell_entry(CellRows rows, ivec3 word, uint k) { return cell_case(rows, k); }
uint cell_work(uint cube_case) { return triangle_count(cube_case); }
