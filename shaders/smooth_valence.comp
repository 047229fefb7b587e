#version 430
// Smoothing pass 1 of 6, once per mesh, one invocation per triangle: count each vertex's
// outgoing half-edges (a->b, b->c, c->a) into ends[] (zeroed before; scanned after), and keep
// each half-edge's rank among its start vertex's (the count before it) for smooth_fill.comp.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

uniform uint u_triangle_count;
layout(std430, binding = BLOCK_MESH_INDICES) readonly buffer Triangles { uint corners[]; };
layout(r32ui, binding = UNIT_RANKS) writeonly uniform uimage2D u_ranks;

void main() {
    uint t = vertex_index();
    if (t >= u_triangle_count) return;
    for (uint c = 0u; c < 3u; c++) imageStore(u_ranks, item_texel(3u * t + c), uvec4(atomicAdd(ends[corners[3u * t + c]], 1u)));
}
