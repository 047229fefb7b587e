#version 430
// Pass 2: per word, count the vertices it owns (per axis) and the triangles of its cells.
// Invocation u_word_count writes the zero that the exclusive scans turn into totals.
layout(local_size_x = 64) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"

layout(std430, binding = 1) writeonly buffer VertexCounts { uint vertex_counts[]; };
layout(std430, binding = 2) writeonly buffer TriangleCounts { uint triangle_counts[]; };
layout(std430, binding = 3) writeonly buffer AxisCounts { uint axis_counts[]; };
layout(std430, binding = 4) readonly buffer CaseTable { uint case_table[]; };

void main() {
    uint word_id = invocation_index();
    if (word_id >= u_word_count) {
        if (word_id == u_word_count) { vertex_counts[word_id] = 0u; triangle_counts[word_id] = 0u; }
        return;
    }
    ivec3 p = word_origin(word_id);
    int w = p.z / 32;

    uvec3 crossing = crossing_masks(p.x, p.y, w);
    uint n0 = uint(bitCount(crossing.x)), n1 = uint(bitCount(crossing.y)), n2 = uint(bitCount(crossing.z));
    vertex_counts[word_id] = n0 + n1 + n2;
    axis_counts[word_id] = n0 | (n1 << 8);  // the triangle pass finds a neighbour word's axis offsets here

    uint triangles = 0u;
    if (p.x + 1 < u_dims.x && p.y + 1 < u_dims.y) {
        CellRows rows = cell_rows(p.x, p.y, w);
        uint cells = mixed_cells(rows, w);
        while (cells != 0u) {
            uint k = uint(findLSB(cells));
            cells &= cells - 1u;
            triangles += case_table[CASE_COUNTS_OFFSET + cell_case(rows, k)];
        }
    }
    triangle_counts[word_id] = triangles;
}
