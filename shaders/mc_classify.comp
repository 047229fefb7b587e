#version 430
// Marching cubes' pass 3 (cells_classify.glsl): per word, the vertices it owns along each axis and
// the triangles of its cells, in one uint (mc_cells.glsl).
layout(local_size_x = BRICK_WORDS) in;
#include "mc_cells.glsl"
#include "cells_classify.glsl"
