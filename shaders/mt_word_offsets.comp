#version 430
// Tetrahedra pass 6, one invocation per active brick: each word's first vertex and first triangle,
// from the brick's scanned offsets plus the words before it in the brick.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_active_bricks.glsl"
#include "mt_common.glsl"

layout(std430, binding = 1) readonly buffer BrickVertexOffsets { uint brick_vertex_offsets[]; };
layout(std430, binding = 2) readonly buffer BrickTriangleOffsets { uint brick_triangle_offsets[]; };
layout(rgba32ui, binding = 2) readonly uniform uimage2D u_word_counts;  // see mt_common.glsl
layout(rg32ui, binding = 3) writeonly uniform uimage2D u_word_offsets;  // (first vertex, first triangle)

void main() {
    uint brick;
    if (!active_brick_of_invocation(brick)) return;
    uvec2 next = uvec2(brick_vertex_offsets[brick], brick_triangle_offsets[brick]);
    for (uint local = 0u; local < WORDS_PER_BRICK; ++local) {
        uint id;
        if (word_of_brick(brick, local, id)) {
            imageStore(u_word_offsets, word_texel(id), uvec4(next, 0u, 0u));
            uvec4 counts = imageLoad(u_word_counts, word_texel(id));
            next += uvec2(mt_vertex_total(counts), counts.z);
        }
    }
}
