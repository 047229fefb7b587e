// The cubes' cell edges for pass 7 (cells_triangles.glsl), after the kind's counts (mc_cells.glsl,
// mc3_cells.glsl) and mc_jobs.glsl: a cell's 12 edges are the axis edges of the four sign rows around it,
// owned by the words of those rows, and the jobs of the vertices a word owns.
#include "cells_triangle_bindings.glsl"

// Where each axis's vertices start in the words owning a cell row's edges, per sign row around
// the cells (component d0 | d1 << 1): in word w, and in word w + 1 (reached from cell 31, only
// along axes 0 and 1).
struct OwnerStarts { uvec4 along0; uvec4 along1; uvec4 along2; uvec4 next0; uvec4 next1; };

// The word's crossing masks per owner row (isoscope.core.case_table: edge = axis * 4 + low; low's bits are
// the owner's offsets along the other two axes, the lower axis first): along axis 0 rows 0 and 2,
// along axis 1 rows 0 and 1 (edges 0, 1 and 4, 5 start at the cell's k; 2, 3 and 6, 7 at k + 1),
// along axis 2 the four rows (edges 8-11).
struct EdgeLines { uvec4 crossing01; uvec4 crossing2; uvec4 start01; };

// Indices of the vertices on the 12 edges of cell k (edge e in component e & 3 of vector e >> 2):
// each is its owner's first vertex along the axis plus the crossings before it in the owner's row.
// Edges at k + 1 of the word's last cell belong to the next word.
struct CellVertices { uvec4 e0; uvec4 e1; uvec4 e2; };


uvec3 axis_starts(uint owner) {
    uint counts = imageLoad(u_word_counts, word_texel(owner)).x;
    uint first = imageLoad(u_word_offsets, word_texel(owner)).x;
    uint after0 = first + vertices_along(counts, 0u);
    return uvec3(first, after0, after0 + vertices_along(counts, 1u));
}

OwnerStarts owner_starts(ivec3 word, bool need_next) {
    uvec3 s0 = axis_starts(word_id_of(word.x, word.y, word.z));
    uvec3 s1 = axis_starts(word_id_of(word.x + 1, word.y, word.z));
    uvec3 s2 = axis_starts(word_id_of(word.x, word.y + 1, word.z));
    uvec3 s3 = axis_starts(word_id_of(word.x + 1, word.y + 1, word.z));
    OwnerStarts s;
    s.along0 = uvec4(s0.x, s1.x, s2.x, s3.x);
    s.along1 = uvec4(s0.y, s1.y, s2.y, s3.y);
    s.along2 = uvec4(s0.z, s1.z, s2.z, s3.z);
    s.next0 = s.next1 = uvec4(0u);
    if (need_next) {  // only when the word's last cell is cut, so word w + 1 exists
        uvec3 n0 = axis_starts(word_id_of(word.x, word.y, word.z + 1));
        uvec3 n1 = axis_starts(word_id_of(word.x + 1, word.y, word.z + 1));
        uvec3 n2 = axis_starts(word_id_of(word.x, word.y + 1, word.z + 1));
        uvec3 n3 = axis_starts(word_id_of(word.x + 1, word.y + 1, word.z + 1));
        s.next0 = uvec4(n0.x, n1.x, n2.x, n3.x);
        s.next1 = uvec4(n0.y, n1.y, n2.y, n3.y);
    }
    return s;
}

EdgeLines edge_lines(CellRows rows, OwnerStarts starts) {
    uvec4 r = rows.at_k;
    EdgeLines e;
    e.crossing01 = uvec4(r.x ^ r.y, r.z ^ r.w, r.x ^ r.z, r.y ^ r.w);
    e.crossing2 = r ^ (r >> 1);  // bits below a cell's k never need the next word
    e.start01 = uvec4(starts.along0.xz, starts.along1.xy);
    return e;
}

CellVertices cell_vertices(EdgeLines lines, OwnerStarts starts, uint k) {
    uint below = (1u << k) - 1u;
    uvec4 at_k = lines.start01 + uvec4(bitCount(lines.crossing01 & below));  // edges 0, 1, 4, 5
    uvec4 at_k1 = at_k + ((lines.crossing01 >> k) & 1u);  // edges 2, 3, 6, 7
    if (k == uint(WORD_BITS - 1)) at_k1 = uvec4(starts.next0.xz, starts.next1.xy);
    CellVertices v;
    v.e0 = uvec4(at_k.xy, at_k1.xy);
    v.e1 = uvec4(at_k.zw, at_k1.zw);
    v.e2 = starts.along2 + uvec4(bitCount(lines.crossing2 & uvec4(below)));
    return v;
}

uint edge_vertex_index(CellVertices v, uint edge) {
    uvec4 four = edge < 4u ? v.e0 : edge < 8u ? v.e1 : v.e2;
    return pick(four, edge & 3u);
}

// Name each vertex the word owns in its slot, one iteration per vertex, axis by axis.
void write_vertex_jobs(ivec3 word, uint id, uint next, uint count, CellRows rows) {
    uint base = job_base(word, id);
    uint end = next + count;
    uvec3 left = owned_axis_crossings(rows, word);
    for (; next < end; ++next) {  // the lowest bit of the first axis with bits left, by selects
        uint axis = left.x != 0u ? 0u : left.y != 0u ? 1u : 2u;
        uint bits = axis == 0u ? left.x : axis == 1u ? left.y : left.z;
        uvec3 lowest = uvec3(equal(uvec3(axis), uvec3(0u, 1u, 2u))) * (bits & (0u - bits));
        left &= ~lowest;
        vertex_jobs[next - u_job_first] = base | vertex_job_bits(axis, uint(findLSB(bits)));
    }
}

// What names the vertices of a word's cut `cells`, and (cube_enter_cell) of its cell k's edges.
struct CubeEdges { OwnerStarts starts; EdgeLines lines; CellVertices cell; };

CubeEdges cube_edges(CellRows rows, ivec3 word, uint cells) {
    OwnerStarts starts = owner_starts(word, (cells >> uint(WORD_BITS - 1)) != 0u);
    return CubeEdges(starts, edge_lines(rows, starts), CellVertices(uvec4(0u), uvec4(0u), uvec4(0u)));
}

void cube_enter_cell(inout CubeEdges edges, uint k) { edges.cell = cell_vertices(edges.lines, edges.starts, k); }
