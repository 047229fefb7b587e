#version 430
// The trilinear topology's pass 6 (cells_word_offsets.glsl): each word's first vertex, triangle and own
// vertex, and the order in which pass 7 takes a brick's words.
layout(local_size_x = GROUP_SIZE) in;
#include "mc3_cells.glsl"
#include "cells_word_offsets.glsl"
