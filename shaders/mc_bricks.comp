#version 430
// Pass 1, one invocation per brick: does the level cut this brick's value range?
// A brick on one side has zero counts and constant sign words (neighbours' cells read them),
// which it writes here unless its state says they are already there: while a slider moves, most
// bricks stay on their side, and rewriting their words was most of this pass (imageStores cost
// llvmpipe ~2 ns a lane more than a buffer's stores).  The others are appended to the active list
// that every later pass runs over, so an iso change costs only the bricks it can touch.  Ties
// count as inside.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_common.glsl"

layout(r32ui, binding = UNIT_SIGN_WORDS) writeonly uniform uimage2D u_sign_words;
layout(std430, binding = BLOCK_BRICK_VERTICES) writeonly buffer BrickVertexCounts { uint brick_vertex_counts[]; };
layout(std430, binding = BLOCK_BRICK_TRIANGLES) writeonly buffer BrickTriangleCounts { uint brick_triangle_counts[]; };
layout(std430, binding = BLOCK_ACTIVE_BRICKS) buffer ActiveBricks { uint active_count; uint active_bricks[]; };
layout(std430, binding = BLOCK_BRICK_RANGES) readonly buffer BrickRanges { vec2 brick_ranges[]; };
// What each brick's sign words hold: UNKNOWN (as allocated, or written by mc_signs.comp at some
// level), or a side's constants.  Only this pass and mc_signs.comp (active bricks) write them.
layout(std430, binding = BLOCK_BRICK_STATES) buffer BrickStates { uint brick_states[]; };
const uint UNKNOWN = 0u, ALL_OUTSIDE = 1u, ALL_INSIDE = 2u;

void main() {
    uint brick = linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
    if (brick == 0u) {  // the element past the end, which the exclusive scans turn into totals
        brick_vertex_counts[u_brick_count] = 0u;
        brick_triangle_counts[u_brick_count] = 0u;
    }
    if (brick >= u_brick_count) return;
    vec2 range = u_sign > 0.0 ? brick_ranges[brick] : -brick_ranges[brick].yx;
    bool all_inside = range.x >= u_level, all_outside = range.y < u_level;
    if (!all_inside && !all_outside) {
        active_bricks[atomicAdd(active_count, 1u)] = brick;
        brick_states[brick] = UNKNOWN;  // mc_signs.comp writes its words
        return;
    }
    brick_vertex_counts[brick] = 0u;
    brick_triangle_counts[brick] = 0u;
    uint state = all_inside ? ALL_INSIDE : ALL_OUTSIDE;
    if (brick_states[brick] == state) return;
    brick_states[brick] = state;
    ivec3 origin = brick_origin(brick);
    uint bits = all_inside ? point_bits(origin.z) : 0u;
    for (int i = origin.x; i < min(origin.x + BRICK_I, u_dims.x); ++i) {
        for (int j = origin.y; j < min(origin.y + BRICK_J, u_dims.y); ++j) {
            imageStore(u_sign_words, word_texel(word_id_of(i, j, origin.z)), uvec4(bits));
        }
    }
}
