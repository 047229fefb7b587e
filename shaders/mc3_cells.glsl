// The trilinear topology's cell kind (isoscope.gpu.trilinear), for passes 3-7 (cells_*.glsl) and 9
// (mc3_own_vertices.comp): the cubes' cells and edges (mc_triangles.comp names their vertices), with
// each cut cell's triangles taken by its table key (case | faces << 8 | tunnel << 14,
// isoscope.core.trilinear_table) instead of its case.  Some keys add vertices of the cell's own (the
// mean of listed edge vertices), which follow every edge vertex in the cells' order: each word counts
// them, pass 4 sums them per brick into a buffer of their own, scanned on its own, and pass 6 gives
// each word its first (word offsets' z, OWN_VERTICES).
//
// Per word, the counts image (WORD_COUNTS_FORMAT: rg32ui here) holds: x = the vertices it owns along
// axes 0, 1, 2 (6 bits each) | the place pass 7 takes (6 bits, << 26), as the cubes' (mc_cells.glsl);
// y = the triangles of its cells | their own vertices << 16.
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc3_key_table.glsl"

uint vertices_along(uint counts, uint axis) { return (counts >> (6u * axis)) & 63u; }
uint counts_vertices(uvec4 counts) {
    return vertices_along(counts.x, 0u) + vertices_along(counts.x, 1u) + vertices_along(counts.x, 2u);
}
uint counts_triangles(uvec4 counts) { return counts.y & 0xFFFFu; }
uint counts_own(uvec4 counts) { return counts.y >> 16; }
uint counts_taken(uvec4 counts) { return counts.x >> 26; }
uvec4 counts_with_taken(uvec4 counts, uint local) { return uvec4((counts.x & 0x03FFFFFFu) | (local << 26), counts.yzw); }

// The counts of word `word` (the rows' corner 0) at place `place` of its brick, with `work`, the sum of
// its cells' cell_work().
uvec4 word_counts(CellRows rows, ivec3 word, uint work, uint place) {
    uvec3 crossing = owned_axis_crossings(rows, word);
    return uvec4(uint(bitCount(crossing.x)) | (uint(bitCount(crossing.y)) << 6)
                 | (uint(bitCount(crossing.z)) << 12) | (place << 26), work, 0u, 0u);
}

// What a cell adds to its word's counts.y: its key's triangles and own vertices (`header`: cell_entry()).
uint cell_work(uint header) { return triangle_count(header) | (own_count(header) << 16); }

// The header of the cell's table key (mc3_key_table.glsl), the key as isoscope.cpu.compiled_trilinear._cell_key
// decides it: its float64 arithmetic in its order.  `precise`: no multiply-add may be fused, nor anything
// reordered, in what decides the key.
uint cell_entry(CellRows rows, ivec3 word, uint k) {
    uint cube_case = cell_case(rows, k);
    uint info = case_info(cube_case);
    if ((info & NEEDS_SAMPLES) == 0u) return plain_header(info);
    ivec3 p = ivec3(word.xy, word.z * WORD_BITS + int(k));
    double level = double(u_level);
    precise double d0 = double(field_at(p)) - level;
    precise double d1 = double(field_at(p + ivec3(1, 0, 0))) - level;
    precise double d2 = double(field_at(p + ivec3(0, 1, 0))) - level;
    precise double d3 = double(field_at(p + ivec3(1, 1, 0))) - level;
    precise double d4 = double(field_at(p + ivec3(0, 0, 1))) - level;
    precise double d5 = double(field_at(p + ivec3(1, 0, 1))) - level;
    precise double d6 = double(field_at(p + ivec3(0, 1, 1))) - level;
    precise double d7 = double(field_at(p + ivec3(1, 1, 1))) - level;
    // The faces (isoscope.core.case_table.FACE_CORNERS): (0 2 6 4) (1 3 7 5) (0 1 5 4) (2 3 7 6) (0 1 3 2) (4 5 7 6).
    uint faces = face_bit(info, 0u, d0, d2, d6, d4) | face_bit(info, 1u, d1, d3, d7, d5)
               | face_bit(info, 2u, d0, d1, d5, d4) | face_bit(info, 3u, d2, d3, d7, d6)
               | face_bit(info, 4u, d0, d1, d3, d2) | face_bit(info, 5u, d4, d5, d7, d6);
    precise double r0 = d4 - d0, r1 = d5 - d1, r2 = d6 - d2, r3 = d7 - d3;
    precise double a = r0 * r3 - r1 * r2;
    precise double b = (d0 * r3 + d3 * r0) - (d1 * r2 + d2 * r1);
    precise double c = d0 * d3 - d1 * d2;
    precise double minus_two_a = -2.0LF * a;
    uint tunnel = 0u;
    if (a != 0.0LF && (a < 0.0LF ? (b > 0.0LF && b < minus_two_a) : (b < 0.0LF && b > minus_two_a))) {
        double sign_a = a > 0.0LF ? 1.0LF : -1.0LF;
        precise double two_a = 2.0LF * a;
        precise double s0 = (two_a * d0 - b * r0) * sign_a;
        precise double s1 = (two_a * d1 - b * r1) * sign_a;
        precise double s2 = (two_a * d2 - b * r2) * sign_a;
        precise double s3 = (two_a * d3 - b * r3) * sign_a;
        precise double saddle = ((4.0LF * a) * c - b * b) * sign_a;
        bool in0 = s0 >= 0.0LF, in1 = s1 >= 0.0LF, in2 = s2 >= 0.0LF, in3 = s3 >= 0.0LF;
        if (in0 && in3 && !in1 && !in2) tunnel = saddle >= 0.0LF ? 1u : 4u;
        else if (in1 && in2 && !in0 && !in3) tunnel = saddle <= 0.0LF ? 2u : 3u;
    }
    return key_header(cube_case | (faces << 8) | (tunnel << 14));
}
