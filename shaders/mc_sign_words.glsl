// Read access to the packed inside bits written by mc_bricks.comp and mc_signs.comp (image 1).
layout(r32ui, binding = UNIT_SIGN_WORDS) readonly uniform uimage2D u_sign_words;

uint row_word(int i, int j, int w) { return imageLoad(u_sign_words, word_texel(word_id_of(i, j, w))).x; }

// The row's word shifted down by one sample: bit k holds sample k + 1 (from the next word at bit 31).
uint next_samples(int i, int j, int w, uint word) {
    uint carry = (w + 1 < u_words) ? (row_word(i, j, w + 1) & 1u) : 0u;
    return (word >> 1) | (carry << 31);
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

// The sign rows around a row of cells as cell_rows() gives them, with the rows past the grid's
// last row along axis 0 or 1 zero (the edges towards them are masked off by their users).
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

// Per axis, the points of word (i, j, w), the rows' corner 0, whose edge towards +axis changes sign:
// the axis edges it owns, those whose far end is in the grid.
uvec3 owned_axis_crossings(CellRows rows, ivec3 word) {
    uint here = rows.at_k.x;
    uint along0 = word.x + 1 < u_dims.x ? (here ^ rows.at_k.y) & point_bits(word.z) : 0u;
    uint along1 = word.y + 1 < u_dims.y ? (here ^ rows.at_k.z) & point_bits(word.z) : 0u;
    return uvec3(along0, along1, (here ^ rows.at_k1.x) & axis2_edge_bits(word.z));
}

// Case index of cell k: bit c = corner (c & 1, c >> 1 & 1, c >> 2 & 1), as isoscope.core.case_table.
uint cell_case(CellRows rows, uint k) {
    uvec4 low = (rows.at_k >> k) & 1u, high = (rows.at_k1 >> k) & 1u;
    return low.x | (low.y << 1) | (low.z << 2) | (low.w << 3)
         | (high.x << 4) | (high.y << 5) | (high.z << 6) | (high.w << 7);
}
