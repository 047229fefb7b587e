#version 430
// The trilinear topology's pass 4 (cells_brick_sums.glsl): the brick totals of its per-word counts, its
// cells' own vertices among them (OWN_VERTICES).
layout(local_size_x = GROUP_SIZE) in;
#include "mc3_cells.glsl"
#include "cells_brick_sums.glsl"
