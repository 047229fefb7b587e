#version 430
// Marching cubes' pass 4 (cells_brick_sums.glsl): the brick totals of its per-word counts.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_cells.glsl"
#include "cells_brick_sums.glsl"
