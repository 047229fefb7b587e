// Read access to the packed inside bits written by mc_bricks.comp and mc_signs.comp (image 1).
layout(r32ui, binding = UNIT_SIGN_WORDS) readonly uniform uimage2D u_sign_words;

uint row_word(int i, int j, int w) { return imageLoad(u_sign_words, word_texel(word_id_of(i, j, w))).x; }

// The row's word shifted down by one sample: bit k holds sample k + 1 (from the next word at bit 31).
uint next_samples(int i, int j, int w, uint word) {
    uint carry = (w + 1 < u_words) ? (row_word(i, j, w + 1) & 1u) : 0u;
    return (word >> 1) | (carry << 31);
}

// Per axis, the word's points whose edge towards +axis changes sign (the edges they own).
uvec3 crossing_masks(int i, int j, int w) {
    uint here = row_word(i, j, w);
    uint along0 = (i + 1 < u_dims.x) ? (here ^ row_word(i + 1, j, w)) & point_bits(w) : 0u;
    uint along1 = (j + 1 < u_dims.y) ? (here ^ row_word(i, j + 1, w)) & point_bits(w) : 0u;
    uint along2 = (here ^ next_samples(i, j, w, here)) & axis2_edge_bits(w);
    return uvec3(along0, along1, along2);
}

// The four sign rows around a row of cells, component d0 | d1 << 1, at k and at k + 1.
struct CellRows { uvec4 at_k; uvec4 at_k1; };

CellRows cell_rows(int i, int j, int w) {
    CellRows rows;
    rows.at_k = uvec4(row_word(i, j, w), row_word(i + 1, j, w), row_word(i, j + 1, w), row_word(i + 1, j + 1, w));
    rows.at_k1 = uvec4(next_samples(i, j, w, rows.at_k.x), next_samples(i + 1, j, w, rows.at_k.y),
                       next_samples(i, j + 1, w, rows.at_k.z), next_samples(i + 1, j + 1, w, rows.at_k.w));
    return rows;
}

// Cells of the word (i, j, w) with corners on both sides of the level.
uint mixed_cells(CellRows rows, int w) {
    uvec4 any_in = rows.at_k | rows.at_k1, all_in = rows.at_k & rows.at_k1;
    return (any_in.x | any_in.y | any_in.z | any_in.w) & ~(all_in.x & all_in.y & all_in.z & all_in.w)
           & axis2_edge_bits(w);
}

bool has_cells(int i, int j) { return i + 1 < u_dims.x && j + 1 < u_dims.y; }

// crossing_masks() of the word at rows' corner 0, from rows already loaded (needs has_cells).
uvec3 crossing_from_rows(CellRows rows, int w) {
    uint here = rows.at_k.x;
    return uvec3((here ^ rows.at_k.y) & point_bits(w), (here ^ rows.at_k.z) & point_bits(w),
                 (here ^ rows.at_k1.x) & axis2_edge_bits(w));
}

// Case index of cell k: bit c = corner (c & 1, c >> 1 & 1, c >> 2 & 1), as isoscope.core.case_table.
uint cell_case(CellRows rows, uint k) {
    uvec4 low = (rows.at_k >> k) & 1u, high = (rows.at_k1 >> k) & 1u;
    return low.x | (low.y << 1) | (low.z << 2) | (low.w << 3)
         | (high.x << 4) | (high.y << 5) | (high.z << 6) | (high.w << 7);
}
