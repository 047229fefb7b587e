#version 430
// Marching cubes' pass 6 (cells_word_offsets.glsl): each word's first vertex and triangle, and the
// order in which pass 7 takes a brick's words.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_cells.glsl"
#include "cells_word_offsets.glsl"
