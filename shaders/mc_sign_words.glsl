// Read access to the packed inside bits written by mc_signs.comp (binding 0).
layout(std430, binding = 0) readonly buffer SignWords { uint sign_words[]; };

uint row_word(int i, int j, int w) { return sign_words[word_id_of(i, j, w)]; }

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

// The four sign rows around a row of cells, indexed d0 | d1 << 1, at k and at k + 1.
struct CellRows { uint at_k[4]; uint at_k1[4]; };

CellRows cell_rows(int i, int j, int w) {
    CellRows rows;
    for (int r = 0; r < 4; ++r) {
        int ri = i + (r & 1), rj = j + (r >> 1);
        rows.at_k[r] = row_word(ri, rj, w);
        rows.at_k1[r] = next_samples(ri, rj, w, rows.at_k[r]);
    }
    return rows;
}

// Cells of the word (i, j, w) with corners on both sides of the level.
uint mixed_cells(CellRows rows, int w) {
    uint any_in = 0u, all_in = 0xFFFFFFFFu;
    for (int r = 0; r < 4; ++r) {
        any_in |= rows.at_k[r] | rows.at_k1[r];
        all_in &= rows.at_k[r] & rows.at_k1[r];
    }
    return any_in & ~all_in & axis2_edge_bits(w);
}

bool has_cells(int i, int j) { return i + 1 < u_dims.x && j + 1 < u_dims.y; }

// Case index of cell k: bit c = corner (c & 1, c >> 1 & 1, c >> 2 & 1), as app/case_table.py.
uint cell_case(CellRows rows, uint k) {
    uint c = 0u;
    for (int r = 0; r < 4; ++r) {
        c |= ((rows.at_k[r] >> k) & 1u) << uint(r);
        c |= ((rows.at_k1[r] >> k) & 1u) << uint(r + 4);
    }
    return c;
}
