#version 430
// The trilinear topology's pass 7 (cells_triangles.glsl): the cubes' edges and vertex jobs
// (mc_cube_edges.glsl), each cell's triangles by its key, and for each own vertex of a cell its job for
// pass 9 (mc3_own_vertices.comp): the indices of the edge vertices it is the mean of, in edge order,
// OWN_EDGES slots ended by ~0 where fewer.  A cell's own vertex n is vertex own_first + n, counted
// along the word's cells from its first (word offsets' z).
layout(local_size_x = BRICK_WORDS) in;
#include "mc3_cells.glsl"
#include "mc_jobs.glsl"
#include "mc_cube_edges.glsl"

uniform uint u_own_base;  // the first own vertex: the edge vertices' total
layout(std430, binding = BLOCK_OWN_JOBS) writeonly buffer OwnJobs { uint own_jobs[]; };

// The cubes' edges; the cell's first own vertex, the next cell's, and whether this run writes the jobs.
struct WordEdges { CubeEdges cube; uint own_first; uint own_next; bool jobs; };

#include "cells_triangles.glsl"

WordEdges word_edges(CellRows rows, ivec3 word, uint cells) {
    uvec4 first = imageLoad(u_word_offsets, word_texel(word_id_of(word.x, word.y, word.z)));
    return WordEdges(cube_edges(rows, word, cells), first.z, first.z, writes_jobs(first.y));
}

void enter_cell(inout WordEdges edges, uint k, uint header) {
    cube_enter_cell(edges.cube, k);
    uint own = own_count(header);
    edges.own_first = edges.own_next;
    edges.own_next += own;
    if (!edges.jobs) return;
    for (uint n = 0u; n < own; ++n) {
        uint mask = own_mask(header, n);
        uint slot = (edges.own_first + n - u_own_base) * OWN_EDGES;
        uint written = 0u;
        for (uint e = 0u; e < 12u; ++e) {
            if (((mask >> e) & 1u) != 0u) own_jobs[slot + written++] = edge_vertex_index(edges.cube.cell, e);
        }
        if (written < OWN_EDGES) own_jobs[slot + written] = 0xFFFFFFFFu;
    }
}

uint vertex_index(WordEdges edges, uint code) {
    return code < FIRST_OWN_CODE ? edge_vertex_index(edges.cube.cell, code) : edges.own_first + code - FIRST_OWN_CODE;
}
