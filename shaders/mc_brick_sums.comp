#version 430
// Pass 4, one invocation per active brick: the brick's vertex and triangle totals, for the scans.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_common.glsl"
#include "mc_active_bricks.glsl"

layout(std430, binding = BLOCK_BRICK_VERTICES) writeonly buffer BrickVertexCounts { uint brick_vertex_counts[]; };
layout(std430, binding = BLOCK_BRICK_TRIANGLES) writeonly buffer BrickTriangleCounts { uint brick_triangle_counts[]; };
layout(r32ui, binding = UNIT_WORD_COUNTS) readonly uniform uimage2D u_word_counts;

void main() {
    uint brick;
    if (!active_brick_of_invocation(brick)) return;
    uint vertices = 0u, triangles = 0u;
    for (uint local = 0u; local < WORDS_PER_BRICK; ++local) {
        uint id;
        if (word_of_brick(brick, local, id)) {
            uint counts = imageLoad(u_word_counts, word_texel(id)).x;
            vertices += vertex_total(counts);
            triangles += triangle_total(counts);
        }
    }
    brick_vertex_counts[brick] = vertices;
    brick_triangle_counts[brick] = triangles;
}
