#version 430
// Smoothing pass 3 of 5, once per mesh, one invocation per triangle (after smooth_load.comp has put
// each vertex's first slot in u_rings): half-edge h = from->to goes to slot first[from] + rank[h],
// its rank from smooth_valence.comp.  No atomics: on llvmpipe each costs several image loads.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

uniform uint u_triangle_count;
layout(std430, binding = 6) readonly buffer Triangles { uint corners[]; };
layout(r32ui, binding = 3) writeonly uniform uimage2D u_neighbours;
layout(rg32ui, binding = 4) readonly uniform uimage2D u_rings;
layout(r32ui, binding = 5) readonly uniform uimage2D u_ranks;

void place(uint half_edge, uint from, uint to) {
    uint slot = imageLoad(u_rings, item_texel(from)).x + imageLoad(u_ranks, item_texel(half_edge)).x;
    imageStore(u_neighbours, item_texel(slot), uvec4(to));
}

void main() {
    uint t = vertex_index();
    if (t >= u_triangle_count) return;
    uvec3 tri = uvec3(corners[3u * t], corners[3u * t + 1u], corners[3u * t + 2u]);
    place(3u * t, tri.x, tri.y);
    place(3u * t + 1u, tri.y, tri.z);
    place(3u * t + 2u, tri.z, tri.x);
}
