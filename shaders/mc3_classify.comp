#version 430
// The trilinear topology's pass 3 (cells_classify.glsl): per word, the vertices it owns along each axis,
// and its cells' triangles and own vertices by their table keys (mc3_cells.glsl).
layout(local_size_x = BRICK_WORDS) in;
#include "mc3_cells.glsl"
#include "cells_classify.glsl"
