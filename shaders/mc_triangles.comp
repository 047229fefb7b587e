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

// Index of the vertex on cell edge `edge` (see app/case_table.py) of cell (i, j, 32w + k).
uint vertex_index(CellRows rows, ivec3 word, uint k, uint edge) {
    uint axis = edge >> 2, low = edge & 3u;
    uvec3 offset = axis == 0u ? uvec3(0u, low & 1u, low >> 1)
                 : axis == 1u ? uvec3(low & 1u, 0u, low >> 1)
                              : uvec3(low & 1u, low >> 1, 0u);
    uint row = offset.x | (offset.y << 1);  // the owner's sign row among the four around the cells
    uint bit = k + offset.z;
    int owner_w = word.z;
    uint rank = 0u;
    if (bit == 32u) {
        owner_w += 1;  // owned by the first point of the next word: first of its axis there
    } else {
        uint here = rows.at_k[row];
        uint crossing = axis == 0u ? here ^ rows.at_k[row | 1u]
                      : axis == 1u ? here ^ rows.at_k[row | 2u]
                                   : here ^ (here >> 1);  // bits below `bit` never need the next word
        rank = uint(bitCount(crossing & ((1u << bit) - 1u)));
    }
    uint owner = word_id_of(word.x + int(offset.x), word.y + int(offset.y), owner_w);
    uint counts = word_counts[owner];
    uint axis_start = axis == 0u ? 0u
                    : axis == 1u ? vertices_along(counts, 0u)
                                 : vertices_along(counts, 0u) + vertices_along(counts, 1u);
    return word_offsets[owner].x + axis_start + rank;
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
    while (cells != 0u) {
        uint k = uint(findLSB(cells));
        cells &= cells - 1u;
        uint c = cell_case(rows, k);
        uint triangles = triangle_count(c);
        for (uint t = 0u; t < triangles; ++t) {
            uint edges = triangle_edges(c, t);
            for (uint corner = 0u; corner < 3u; ++corner) {
                indices[3u * next + corner] = vertex_index(rows, word, k, (edges >> (4u * corner)) & 15u);
            }
            next++;
        }
    }
}
