#version 430
// Tetrahedra pass 6, one invocation per active brick: each word's first vertex and first triangle,
// from the brick's scanned offsets plus the words before it in the brick.  Then, in a whole brick,
// the order in which mt_triangles.comp's invocations take its words (counts.w, see mt_common.glsl):
// by their work (vertices + triangles, its loop iterations), so that the 8 words that share a
// SIMD vector on llvmpipe have similar loop counts.  In grid order a vector ran as long as its
// busiest word, its lanes about 55% busy on gyroid and noise; sorted, about 80%.  A counting sort
// into SORT_BUCKETS buckets of the brick's work range is nearly as good as a full sort, and cheap:
// the bucket counters are bytes, four to a uint.  Bricks cut by the grid's end keep grid order.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_active_bricks.glsl"
#include "mt_common.glsl"

layout(std430, binding = BLOCK_BRICK_VERTICES) readonly buffer BrickVertexOffsets { uint brick_vertex_offsets[]; };
layout(std430, binding = BLOCK_BRICK_TRIANGLES) readonly buffer BrickTriangleOffsets { uint brick_triangle_offsets[]; };
layout(rgba32ui, binding = UNIT_WORD_COUNTS) uniform uimage2D u_word_counts;           // see mt_common.glsl; this pass sets w
layout(rg32ui, binding = UNIT_WORD_OFFSETS) writeonly uniform uimage2D u_word_offsets;  // (first vertex, first triangle)

const uint SORT_BUCKETS = 16u;  // four uints of byte counters (a brick's 64 words fit a byte)

// A one in bucket b's byte counter.
uvec4 bucket_one(uint b) { return uvec4(equal(uvec4(b >> 2), uvec4(0u, 1u, 2u, 3u))) << (8u * (b & 3u)); }

// The grid word id of word `local` of a whole brick whose first word is `first`.
uint id_in_brick(uint first, uint local) {
    return first + (local / uint(BRICK_J) * uint(u_dims.y) + local % uint(BRICK_J)) * uint(u_words);
}

uint bucket_of(uint id, float scale) {
    uint work = mt_work(imageLoad(u_word_counts, word_texel(id)));
    return min(uint(float(work) * scale), SORT_BUCKETS - 1u);
}

void main() {
    uint brick;
    if (!active_brick_of_invocation(brick)) return;
    uvec2 next = uvec2(brick_vertex_offsets[brick], brick_triangle_offsets[brick]);
    uint most = 0u;
    bool whole = true;
    for (uint local = 0u; local < WORDS_PER_BRICK; ++local) {
        uint id;
        if (word_of_brick(brick, local, id)) {
            imageStore(u_word_offsets, word_texel(id), uvec4(next, 0u, 0u));
            uvec4 counts = imageLoad(u_word_counts, word_texel(id));
            next += uvec2(mt_vertex_total(counts), counts.z);
            most = max(most, mt_work(counts));
        } else {
            whole = false;
        }
    }
    if (!whole || most == 0u) return;  // mt_classify.comp left each word its own place

    uint first;
    word_of_brick(brick, 0u, first);
    float scale = float(SORT_BUCKETS) / float(most + 1u);  // bucket = work * 16 / (most + 1) < 16
    uvec4 counters = uvec4(0u);
    for (uint local = 0u; local < WORDS_PER_BRICK; ++local) counters += bucket_one(bucket_of(id_in_brick(first, local), scale));
    // Exclusive prefix sums of the byte counters: within a uint by a multiply, then across them.
    uvec4 sums = (counters * 0x01010101u) >> 24;
    uvec4 before = uvec4(0u, sums.x, sums.x + sums.y, sums.x + sums.y + sums.z);
    uvec4 starts = counters * 0x01010100u + before * 0x01010101u;
    for (uint local = 0u; local < WORDS_PER_BRICK; ++local) {  // word `local` takes the next place of its bucket
        uint b = bucket_of(id_in_brick(first, local), scale);
        uint place = id_in_brick(first, (pick(starts, b >> 2) >> (8u * (b & 3u))) & 255u);
        starts += bucket_one(b);
        uvec4 counts = imageLoad(u_word_counts, word_texel(place));
        imageStore(u_word_counts, word_texel(place), uvec4(counts.xyz, local));
    }
}
