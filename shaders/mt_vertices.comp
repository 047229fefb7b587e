#version 430
// Marching tetrahedra's pass 8 (cells_vertices.glsl): a vertex on any of the seven kinds of edge.
layout(local_size_x = GROUP_SIZE) in;
#include "mt_jobs.glsl"

// A flat field's normal points along the edge, away from its inside end: a unit vector in physical
// units, as a diagonal edge's step is not one.
vec3 flat_normal(ivec3 step) { return normalize(vec3(step) * u_spacing); }

#include "cells_vertices.glsl"
