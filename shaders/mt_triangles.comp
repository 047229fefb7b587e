#version 430
// Marching tetrahedra's pass 7 (cells_triangles.glsl): a tetrahedron's edges are owned by the four
// sign rows around the cells, at k or k + 1, possibly in word w + 1; each vertex's job is its edge's
// start sample and kind (mt_jobs.glsl).
layout(local_size_x = BRICK_WORDS) in;
#include "mt_cells.glsl"
#include "mt_jobs.glsl"

// Per sign row around the cells (component d0 | d1 << 1), its word's first vertex and kind starts.
struct Owners { uvec4 first; uvec4 starts_x; uvec4 starts_y; };

// The first vertices, in word w + 1, of the edges that cell 31's corners 4, 5 and 6 own there (bit 0):
// corner 4's kinds 0, 1 and 3, corner 5's kind 1, corner 6's kind 0 (the kinds with no step along axis 2).
struct Wrapped { uvec4 corner4_and_5; uint corner6; };

// The word's rows and owners, and the cell entered last.
struct WordEdges { CellRows rows; Owners here; Wrapped next; uint k; };

#include "cells_triangles.glsl"

uvec3 owner(int i, int j, int w) {  // (first vertex, starts_x, starts_y) of word (i, j, w)
    uint id = word_id_of(i, j, w);
    return uvec3(imageLoad(u_word_offsets, word_texel(id)).x, imageLoad(u_word_counts, word_texel(id)).xy);
}

Owners owners_at(ivec3 word, int w) {
    uvec3 a = owner(word.x, word.y, w), b = owner(word.x + 1, word.y, w);
    uvec3 c = owner(word.x, word.y + 1, w), d = owner(word.x + 1, word.y + 1, w);
    return Owners(uvec4(a.x, b.x, c.x, d.x), uvec4(a.y, b.y, c.y, d.y), uvec4(a.z, b.z, c.z, d.z));
}

uint first_of_kind(Owners o, uint row, uint kind) {
    return pick(o.first, row) + kind_start(pick(o.starts_x, row), pick(o.starts_y, row), kind);
}

Wrapped wrapped_owners(ivec3 word) {
    Owners next = owners_at(word, word.z + 1);
    return Wrapped(uvec4(first_of_kind(next, 0u, 0u), first_of_kind(next, 0u, 1u), first_of_kind(next, 0u, 3u),
                         first_of_kind(next, 1u, 1u)), first_of_kind(next, 2u, 0u));
}

WordEdges word_edges(CellRows rows, ivec3 word, uint cells) {
    Wrapped next = Wrapped(uvec4(0u), 0u);
    if ((cells >> uint(WORD_BITS - 1)) != 0u) next = wrapped_owners(word);  // word w + 1 exists then
    return WordEdges(rows, owners_at(word, word.z), next, 0u);
}

void enter_cell(inout WordEdges edges, uint k, uint cell_case) { edges.k = k; }

// Index of the vertex on the tetrahedron edge `code` (corner | kind << 3) of cell k of the word.
// Selects, not branches: llvmpipe runs both sides of a branch whenever one lane takes it.
uint vertex_index(WordEdges edges, uint code) {
    uint corner = code & 7u, kind = code >> 3;
    uint row = corner & 3u, bit = edges.k + (corner >> 2);
    uint below = (1u << (bit & uint(WORD_BITS - 1))) - 1u;  // bits below `bit`; none past the word
    uint index = first_of_kind(edges.here, row, kind) + uint(bitCount(kind_crossing(edges.rows, row, kind) & below));
    uint wrapped = corner == 4u ? (kind == 0u ? edges.next.corner4_and_5.x : kind == 1u ? edges.next.corner4_and_5.y
                                                                                    : edges.next.corner4_and_5.z)
                 : corner == 5u ? edges.next.corner4_and_5.w : edges.next.corner6;
    return bit == uint(WORD_BITS) ? wrapped : index;
}

// Write the job of each vertex the word owns: one iteration per vertex, kind by kind, as the cubes
// do axis by axis.  Not a loop per kind: the SIMD lanes (words) of a vector would then run each
// kind's loop as long as their busiest, the sum of seven maxima instead of one.
void write_vertex_jobs(ivec3 word, uint id, uint next, uint count, CellRows rows) {
    uint end = next + count;
    uint kind = 0u, bits = owned_crossings(rows, word, 0u);
    for (; next < end; ++next) {
        while (bits == 0u) bits = owned_crossings(rows, word, ++kind);
        uint b = uint(findLSB(bits));
        bits &= bits - 1u;
        ivec3 start = ivec3(word.xy, word.z * WORD_BITS + int(b));
        vertex_jobs[next - u_job_first] = mt_job(start, kind);
    }
}
