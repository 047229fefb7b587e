#version 430
// Marching cubes' pass 8 (cells_vertices.glsl): a vertex on an axis edge.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_jobs.glsl"

// A flat field's normal points along the edge, away from its inside end.
vec3 flat_normal(ivec3 step) { return vec3(step); }

#include "cells_vertices.glsl"
