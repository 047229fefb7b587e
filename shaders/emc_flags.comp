#version 430
// Extended-MC pass 0, one invocation per vertex of the plain mesh: can this vertex's cells hold a
// feature?  core.sharp.cells.vertex_may_bend step for step (see there why the test is conservative):
// for each of the (up to) four cells around the vertex's edge, is its normal more than the feature
// half-angle (u_cos_half, with a margin) from the cell's mean gradient direction?  The four cells'
// 18 samples are loaded once; all is done in the edge's frame (u, w across it, a along it).  Where no vertex
// says yes, no cell's normals open wider than the feature angle and the Extended-MC mesh is the
// plain one: isoscope.gpu.sharp_features then skips reading the mesh back.
// Writes flags[0] = 1 if any vertex says yes; with FLAG_EACH (tests) flags[1 + vertex] per vertex.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_common.glsl"

uniform uint u_vertex_count;
uniform float u_cos_half;
layout(std430, binding = BLOCK_MESH_VERTICES) readonly buffer Vertices { float vertex_data[]; };
layout(std430, binding = BLOCK_FLAGS) buffer Flags { uint flags[]; };

// field_at(p) for p inside the grid: unsigned / and % by the constant compile to a shift and a mask
// (sample_at's signed ones cost this pass over half its time).
float sample_in_grid(ivec3 p) {
    uint z = uint(p.z);
    return u_sign * pick(quad_at(p.x, p.y, int(z / uint(SAMPLES_PER_TEXEL))), z % uint(SAMPLES_PER_TEXEL));
}

// The field's mean gradient over a cell, in the frame (u, w, a) of the vertex's edge (a along it):
// each axis the mean of the cell's four edge differences.  f_ijk: the corner at +i u, +j w, +k a.
vec3 cell_gradient(float f000, float f001, float f010, float f011, float f100, float f101, float f110,
                   float f111, vec3 step) {
    return vec3((f100 - f000) + (f101 - f001) + ((f110 - f010) + (f111 - f011)),
                (f010 - f000) + (f011 - f001) + ((f110 - f100) + (f111 - f101)),
                (f001 - f000) + (f011 - f010) + ((f101 - f100) + (f111 - f110))) / (4.0 * step);
}

// Is `normal` (in the edge's frame) more than the half-angle from the cell's outward direction,
// or has the cell none?
bool bends(vec3 normal, vec3 g) {
    float len = length(g);
    return !(len > 0.0) || dot(normal, -g / len) < u_cos_half;
}

bool vertex_may_bend(uint index) {
    uint base = index * uint(VERTEX_FLOATS);
    vec3 position = vec3(vertex_data[base], vertex_data[base + 1u], vertex_data[base + 2u]);
    vec3 normal = vec3(vertex_data[base + 4u], vertex_data[base + 5u], vertex_data[base + 6u]);
    // The vertex's edge, as core.sharp.eno.edge_of_vertex finds it; a vertex off the grid's edges
    // (a smoothed mesh) has no cells to test: yes.
    vec3 g = position / u_spacing;
    vec3 off = abs(g - roundEven(g));
    bvec3 along = greaterThan(off, vec3(1e-3));
    if (int(along.x) + int(along.y) + int(along.z) != 1) return true;
    ivec3 start = ivec3(mix(roundEven(g), floor(g), along));
    // The edge's frame: u, w across it (ascending axes), a along it; normal and spacing in it.
    ivec3 a = ivec3(along);
    ivec3 u = along.x ? ivec3(0, 1, 0) : ivec3(1, 0, 0);
    ivec3 w = along.z ? ivec3(0, 1, 0) : ivec3(0, 0, 1);
    vec3 n = vec3(dot(normal, vec3(u)), dot(normal, vec3(w)), dot(normal, vec3(a)));
    vec3 step = vec3(dot(u_spacing, vec3(u)), dot(u_spacing, vec3(w)), dot(u_spacing, vec3(a)));
    // The 3 x 3 x 2 samples of the four cells around the edge, s<i><j><k> at (i - 1) u + (j - 1) w + k a
    // (clamped into the grid: a cell past the grid's side holds no triangle and is not tested).
    // Written out: llvmpipe turns arrays indexed in loops into scratch-memory traffic.
#define S(i, j, k) sample_in_grid(clamp(start + (i - 1) * u + (j - 1) * w + k * a, ivec3(0), u_dims - 1))
    float s000 = S(0, 0, 0), s001 = S(0, 0, 1), s010 = S(0, 1, 0), s011 = S(0, 1, 1), s020 = S(0, 2, 0);
    float s021 = S(0, 2, 1), s100 = S(1, 0, 0), s101 = S(1, 0, 1), s110 = S(1, 1, 0), s111 = S(1, 1, 1);
    float s120 = S(1, 2, 0), s121 = S(1, 2, 1), s200 = S(2, 0, 0), s201 = S(2, 0, 1), s210 = S(2, 1, 0);
    float s211 = S(2, 1, 1), s220 = S(2, 2, 0), s221 = S(2, 2, 1);
#undef S
    // Cells start - u - w, start - u, start - w, start; along u and w, cells from -1 or 0 exist.
    bvec2 low = greaterThan(ivec2(dot(start, u), dot(start, w)), ivec2(0));
    bvec2 high = lessThan(ivec2(dot(start, u), dot(start, w)), ivec2(dot(u_dims, u), dot(u_dims, w)) - 1);
    return (low.x && low.y && bends(n, cell_gradient(s000, s001, s010, s011, s100, s101, s110, s111, step)))
        || (low.x && high.y && bends(n, cell_gradient(s010, s011, s020, s021, s110, s111, s120, s121, step)))
        || (high.x && low.y && bends(n, cell_gradient(s100, s101, s110, s111, s200, s201, s210, s211, step)))
        || (high.x && high.y && bends(n, cell_gradient(s110, s111, s120, s121, s210, s211, s220, s221, step)));
}

void main() {
    uint index = linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
    if (index >= u_vertex_count) return;
#ifndef FLAG_EACH
    if (flags[0] != 0u) return;  // one is enough: groups that start after it skip their work (noise)
#endif
    bool bent = vertex_may_bend(index);
#ifdef FLAG_EACH
    flags[1u + index] = bent ? 1u : 0u;
#endif
    if (bent && flags[0] == 0u) flags[0] = 1u;  // every writer writes the same 1: no atomic needed
}
