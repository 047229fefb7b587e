#version 430
// Marching tetrahedra's pass 3 (cells_classify.glsl), after mc_bricks and mc_signs: per word, where
// each edge kind's vertices start among its own, their total, and the triangles of its cells'
// tetrahedra (mt_cells.glsl).
layout(local_size_x = BRICK_WORDS) in;
#include "mt_cells.glsl"
#include "cells_classify.glsl"
