#version 430
// Smoothing pass 2 of 5, once per mesh, one invocation per triangle: after the exclusive scan
// ends[v] is vertex v's first slot; each half-edge takes the next slot of its start vertex, so
// when all are placed ends[v] is one past v's last slot (hence the buffer's name).  The order
// within a list depends on the atomics; the sums over it differ only by float rounding.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

uniform uint u_triangle_count;
layout(std430, binding = 6) readonly buffer Triangles { uint corners[]; };
layout(r32ui, binding = 3) writeonly uniform uimage2D u_neighbours;

void place(uint from, uint to) { imageStore(u_neighbours, item_texel(atomicAdd(ends[from], 1u)), uvec4(to)); }

void main() {
    uint t = vertex_index();
    if (t >= u_triangle_count) return;
    uvec3 tri = uvec3(corners[3u * t], corners[3u * t + 1u], corners[3u * t + 2u]);
    place(tri.x, tri.y);
    place(tri.y, tri.z);
    place(tri.z, tri.x);
}
