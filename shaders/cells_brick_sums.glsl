// Pass 4, one invocation per active brick: the brick's vertex and triangle totals, for the scans.
// For any cell kind: the .comp includes the kind's file (mc_cells.glsl, mt_cells.glsl) before this.
#include "mc_active_bricks.glsl"
layout(std430, binding = BLOCK_BRICK_VERTICES) writeonly buffer BrickVertexCounts { uint brick_vertex_counts[]; };
layout(std430, binding = BLOCK_BRICK_TRIANGLES) writeonly buffer BrickTriangleCounts { uint brick_triangle_counts[]; };
layout(WORD_COUNTS_FORMAT, binding = UNIT_WORD_COUNTS) readonly uniform uimage2D u_word_counts;
#ifdef OWN_VERTICES  // the cells' own vertices (mc3_cells.glsl), summed and scanned on their own
layout(std430, binding = BLOCK_BRICK_OWN_VERTICES) writeonly buffer BrickOwnCounts { uint brick_own_counts[]; };
#endif

void main() {
    uint brick;
    if (!active_brick_of_invocation(brick)) return;
    uvec2 total = uvec2(0u);
    uint own = 0u;
    for (uint local = 0u; local < WORDS_PER_BRICK; ++local) {
        uint id;
        if (word_of_brick(brick, local, id)) {
            uvec4 counts = imageLoad(u_word_counts, word_texel(id));
            total += uvec2(counts_vertices(counts), counts_triangles(counts));
#ifdef OWN_VERTICES
            own += counts_own(counts);
#endif
        }
    }
    brick_vertex_counts[brick] = total.x;
    brick_triangle_counts[brick] = total.y;
#ifdef OWN_VERTICES
    brick_own_counts[brick] = own;
#endif
}
