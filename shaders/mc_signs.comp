#version 430
// Pass 1, over every brick: pack the inside bit of every sample, 32 per word along axis 2.
// A brick whose range lies on one side of the level writes constant words without reading
// the volume and gets zero counts; the others are appended to the active list for the
// passes that follow.  Ties count as inside: the seed's perturbation of exact zeros, done
// symbolically, so no later pass needs a special case.
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"

layout(std430, binding = 0) writeonly buffer SignWords { uint sign_words[]; };
layout(std430, binding = 1) writeonly buffer BrickVertexCounts { uint brick_vertex_counts[]; };
layout(std430, binding = 2) writeonly buffer BrickTriangleCounts { uint brick_triangle_counts[]; };
layout(std430, binding = 7) buffer ActiveBricks { uint active_count; uint active_bricks[]; };
layout(std430, binding = 8) readonly buffer BrickRanges { vec2 brick_ranges[]; };

void main() {
    uint brick = linear_group();
    if (brick >= u_brick_count) return;
    bool exists;
    ivec3 word = brick_word(brick, exists);
    vec2 range = u_sign > 0.0 ? brick_ranges[brick] : -brick_ranges[brick].yx;
    bool all_inside = range.x >= u_level, all_outside = range.y < u_level;

    if (gl_LocalInvocationIndex == 0u) {
        if (brick == 0u) {  // the element past the end, which the exclusive scans turn into totals
            brick_vertex_counts[u_brick_count] = 0u;
            brick_triangle_counts[u_brick_count] = 0u;
        }
        if (all_inside || all_outside) {
            brick_vertex_counts[brick] = 0u;
            brick_triangle_counts[brick] = 0u;
        } else {
            active_bricks[atomicAdd(active_count, 1u)] = brick;
        }
    }
    if (!exists) return;

    uint bits = 0u;
    if (all_inside) {
        bits = point_bits(word.z);
    } else if (!all_outside) {
        int count = min(32, u_dims.z - 32 * word.z);
        for (int b = 0; b < count; ++b) {
            bits |= uint(field_at(ivec3(word.x, word.y, 32 * word.z + b)) >= u_level) << uint(b);
        }
    }
    sign_words[word_id_of(word.x, word.y, word.z)] = bits;
}
