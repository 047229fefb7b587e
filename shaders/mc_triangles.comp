#version 430
// Pass 7, over active bricks, one invocation per word: the triangles of the word's cells, as
// indices of the vertices that the cells' edges own (possibly in a neighbouring word or brick).
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_active_bricks.glsl"
#include "mc_case_table.glsl"

layout(std430, binding = 3) readonly buffer WordCounts { uint word_counts[]; };
layout(std430, binding = 5) readonly buffer WordOffsets { uvec2 word_offsets[]; };  // (vertex, triangle)
layout(std430, binding = 6) writeonly buffer Indices { uint indices[]; };

// Where each axis's vertices start, in the words owning a cell row's edges: for each of the four
// sign rows around the cells (d0 | d1 << 1), in word w and in word w + 1 (reached from cell 31).
struct OwnerStarts { uvec3 here[4]; uvec3 next[4]; };

uvec3 axis_starts(uint owner) {
    uint counts = word_counts[owner];
    uint first = word_offsets[owner].x;
    uint after0 = first + vertices_along(counts, 0u);
    return uvec3(first, after0, after0 + vertices_along(counts, 1u));
}

OwnerStarts owner_starts(ivec3 word, bool need_next) {
    OwnerStarts s;
    for (int r = 0; r < 4; ++r) {
        int i = word.x + (r & 1), j = word.y + (r >> 1);
        s.here[r] = axis_starts(word_id_of(i, j, word.z));
        // Only vertices on edges along axes 0 and 1 are reached in the next word; rows there may lie
        // past the grid's last word, in which case no cell asks for them.
        s.next[r] = need_next ? axis_starts(word_id_of(i, j, word.z + 1)) : uvec3(0u);
    }
    return s;
}

// Index of the vertex on cell edge `edge` (see app/case_table.py) of cell k of the word.
uint vertex_index(CellRows rows, OwnerStarts starts, uint k, uint edge) {
    uint axis = edge >> 2, low = edge & 3u;
    uvec3 offset = axis == 0u ? uvec3(0u, low & 1u, low >> 1)
                 : axis == 1u ? uvec3(low & 1u, 0u, low >> 1)
                              : uvec3(low & 1u, low >> 1, 0u);
    uint row = offset.x | (offset.y << 1);  // the owner's sign row among the four around the cells
    uint bit = k + offset.z;
    if (bit == 32u) return starts.next[row][axis];  // the next word's first point: first of its axis
    uint here = rows.at_k[row];
    uint crossing = axis == 0u ? here ^ rows.at_k[row | 1u]
                  : axis == 1u ? here ^ rows.at_k[row | 2u]
                               : here ^ (here >> 1);  // bits below `bit` never need the next word
    return starts.here[row][axis] + uint(bitCount(crossing & ((1u << bit) - 1u)));
}

void main() {
    uint brick;
    if (!active_brick(brick)) return;
    bool exists;
    ivec3 word = brick_word(brick, exists);
    if (!exists) return;
    uint id = word_id_of(word.x, word.y, word.z);
    if (triangle_total(word_counts[id]) == 0u) return;
    uint next = word_offsets[id].y;

    CellRows rows = cell_rows(word.x, word.y, word.z);
    uint cells = mixed_cells(rows, word.z);
    OwnerStarts starts = owner_starts(word, (cells >> 31) != 0u);
    while (cells != 0u) {
        uint k = uint(findLSB(cells));
        cells &= cells - 1u;
        uint c = cell_case(rows, k);
        uint triangles = triangle_count(c);
        for (uint t = 0u; t < triangles; ++t) {
            uint edges = triangle_edges(c, t);
            for (uint corner = 0u; corner < 3u; ++corner) {
                indices[3u * next + corner] = vertex_index(rows, starts, k, (edges >> (4u * corner)) & 15u);
            }
            next++;
        }
    }
}
