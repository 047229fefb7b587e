#version 430
// Marching cubes' pass 7 (cells_triangles.glsl): a cell's 12 edges are the axis edges of the four
// sign rows around it, owned by the words of those rows (mc_jobs.glsl for their vertex jobs).
layout(local_size_x = BRICK_WORDS) in;
#include "mc_cells.glsl"
#include "mc_jobs.glsl"

#include "mc_cube_edges.glsl"

struct WordEdges { CubeEdges cube; };

#include "cells_triangles.glsl"

WordEdges word_edges(CellRows rows, ivec3 word, uint cells) { return WordEdges(cube_edges(rows, word, cells)); }
void enter_cell(inout WordEdges edges, uint k, uint cube_case) { cube_enter_cell(edges.cube, k); }
uint vertex_index(WordEdges edges, uint code) { return edge_vertex_index(edges.cube.cell, code); }
