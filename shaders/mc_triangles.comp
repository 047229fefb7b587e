#version 430
// Pass 5: the triangles of each word's cells, as indices of the vertices the edges own.
layout(local_size_x = 64) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"

layout(std430, binding = 1) readonly buffer VertexOffsets { uint vertex_offsets[]; };
layout(std430, binding = 2) readonly buffer TriangleOffsets { uint triangle_offsets[]; };
layout(std430, binding = 3) readonly buffer AxisCounts { uint axis_counts[]; };
layout(std430, binding = 4) readonly buffer CaseTable { uint case_table[]; };
layout(std430, binding = 6) writeonly buffer Indices { uint indices[]; };

// Index of the vertex on cell edge `edge` of cell (i, j, 32w + k); see app/case_table.py for edge ids.
uint vertex_index(CellRows rows, int i, int j, int w, uint k, uint edge) {
    uint axis = edge >> 2, low = edge & 3u;
    uvec3 offset = axis == 0u ? uvec3(0u, low & 1u, low >> 1)
                 : axis == 1u ? uvec3(low & 1u, 0u, low >> 1)
                              : uvec3(low & 1u, low >> 1, 0u);
    uint row = offset.x | (offset.y << 1);  // the owner's sign row among the four around the cells
    uint bit = k + offset.z;
    int owner_w = w;
    uint rank = 0u;
    if (bit == 32u) {
        owner_w += 1;  // owned by the first point of the next word: first of its axis
    } else {
        uint here = rows.at_k[row];
        uint crossing = axis == 0u ? here ^ rows.at_k[row | 1u]
                      : axis == 1u ? here ^ rows.at_k[row | 2u]
                                   : here ^ (here >> 1);  // bits below `bit` never need the next word
        rank = uint(bitCount(crossing & ((1u << bit) - 1u)));
    }
    uint owner = word_id_of(i + int(offset.x), j + int(offset.y), owner_w);
    uint counts = axis_counts[owner];
    uint axis_start = axis == 0u ? 0u : axis == 1u ? (counts & 0xFFu) : (counts & 0xFFu) + ((counts >> 8) & 0xFFu);
    return vertex_offsets[owner] + axis_start + rank;
}

void main() {
    uint word_id = invocation_index();
    if (word_id >= u_word_count) return;
    uint next = triangle_offsets[word_id];
    if (triangle_offsets[word_id + 1u] == next) return;
    ivec3 p = word_origin(word_id);
    int w = p.z / 32;
    CellRows rows = cell_rows(p.x, p.y, w);
    uint cells = mixed_cells(rows, w);
    while (cells != 0u) {
        uint k = uint(findLSB(cells));
        cells &= cells - 1u;
        uint c = cell_case(rows, k);
        uint count = case_table[CASE_COUNTS_OFFSET + c];
        for (uint t = 0u; t < count; ++t) {
            uint edges = case_table[c * MAX_TRIANGLES + t];
            for (uint corner = 0u; corner < 3u; ++corner) {
                indices[3u * next + corner] = vertex_index(rows, p.x, p.y, w, k, (edges >> (4u * corner)) & 15u);
            }
            next++;
        }
    }
}
