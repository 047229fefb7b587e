#version 430
// Smoothing pass 3 of 6, once per mesh, one invocation per triangle (after smooth_load.comp has put
// each vertex's first slot in u_rings): half-edge h = from->to of triangle (from, to, third) goes
// to slot first[from] + rank[h] as (to, third), its rank from smooth_valence.comp: smooth_step.comp
// reads the neighbour, smooth_keep.comp the triangle.  No atomics: on llvmpipe each costs several
// image loads.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

uniform uint u_triangle_count;
layout(std430, binding = BLOCK_MESH_INDICES) readonly buffer Triangles { uint corners[]; };
layout(rg32ui, binding = UNIT_NEIGHBOURS) writeonly uniform uimage2D u_neighbours;
layout(rg32ui, binding = UNIT_RINGS) readonly uniform uimage2D u_rings;
layout(r32ui, binding = UNIT_RANKS) readonly uniform uimage2D u_ranks;

void place(uint half_edge, uint from, uint to, uint third) {
    uint slot = imageLoad(u_rings, item_texel(from)).x + imageLoad(u_ranks, item_texel(half_edge)).x;
    imageStore(u_neighbours, item_texel(slot), uvec4(to, third, 0u, 0u));
}

void main() {
    uint t = vertex_index();
    if (t >= u_triangle_count) return;
    uvec3 tri = uvec3(corners[3u * t], corners[3u * t + 1u], corners[3u * t + 2u]);
    place(3u * t, tri.x, tri.y, tri.z);
    place(3u * t + 1u, tri.y, tri.z, tri.x);
    place(3u * t + 2u, tri.z, tri.x, tri.y);
}
