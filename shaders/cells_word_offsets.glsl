// Pass 6, one invocation per active brick, for any cell kind (its counts functions, mc_cells.glsl or
// mt_cells.glsl, included before this): each word's first vertex and first triangle, from the
// brick's scanned offsets plus the words before it in the brick.  Then, in a whole brick, the order
// in which pass 7's invocations (cells_triangles.glsl) take its words (counts_taken): by their work
// (vertex jobs + triangles, its loop iterations).  On llvmpipe 8 invocations share a SIMD vector and
// loop as long as the busiest of them: in grid order their lanes were 53-57% busy (cubes on the MNI
// T1 and gyroid alike; tetrahedra about 55% on gyroid and noise); sorted by work, the 8 words of a
// vector have similar loop counts (tetrahedra about 80% busy).  A counting sort into SORT_BUCKETS
// buckets of the brick's work range is nearly as good as a full sort, and cheap: the bucket counters
// are bytes, four to a uint.  Bricks cut by the grid's end keep grid order.
#include "mc_active_bricks.glsl"
layout(std430, binding = BLOCK_BRICK_VERTICES) readonly buffer BrickVertexOffsets { uint brick_vertex_offsets[]; };
layout(std430, binding = BLOCK_BRICK_TRIANGLES) readonly buffer BrickTriangleOffsets { uint brick_triangle_offsets[]; };
layout(WORD_COUNTS_FORMAT, binding = UNIT_WORD_COUNTS) uniform uimage2D u_word_counts;  // this pass sets the taken words
// (first vertex, first triangle[, first own vertex: OWN_VERTICES, after every edge vertex])
layout(WORD_OFFSETS_FORMAT, binding = UNIT_WORD_OFFSETS) writeonly uniform uimage2D u_word_offsets;
#ifdef OWN_VERTICES
layout(std430, binding = BLOCK_BRICK_OWN_VERTICES) readonly buffer BrickOwnOffsets { uint brick_own_offsets[]; };
#endif

const uint SORT_BUCKETS = 16u;  // four uints of byte counters (a brick's 64 words fit a byte)

uint work_of(uvec4 counts) { return counts_vertices(counts) + counts_triangles(counts); }

// A one in bucket b's byte counter.
uvec4 bucket_one(uint b) { return uvec4(equal(uvec4(b >> 2), uvec4(0u, 1u, 2u, 3u))) << (8u * (b & 3u)); }

// The grid word id of word `local` of a whole brick whose first word is `first`.
uint id_in_brick(uint first, uint local) {
    return first + (local / uint(BRICK_J) * uint(u_dims.y) + local % uint(BRICK_J)) * uint(u_words);
}

uint bucket_of(uint id, float scale) {
    return min(uint(float(work_of(imageLoad(u_word_counts, word_texel(id)))) * scale), SORT_BUCKETS - 1u);
}

void main() {
    uint brick;
    if (!active_brick_of_invocation(brick)) return;
    uvec2 next = uvec2(brick_vertex_offsets[brick], brick_triangle_offsets[brick]);
    uint own = 0u;
#ifdef OWN_VERTICES
    own = brick_vertex_offsets[u_brick_count] + brick_own_offsets[brick];  // the edge vertices' total first
#endif
    uint most = 0u;
    bool whole = true;
    for (uint local = 0u; local < WORDS_PER_BRICK; ++local) {
        uint id;
        if (word_of_brick(brick, local, id)) {
            imageStore(u_word_offsets, word_texel(id), uvec4(next, own, 0u));
            uvec4 counts = imageLoad(u_word_counts, word_texel(id));
#ifdef OWN_VERTICES
            own += counts_own(counts);
#endif
            next += uvec2(counts_vertices(counts), counts_triangles(counts));
            most = max(most, work_of(counts));
        } else {
            whole = false;
        }
    }
    if (!whole || most == 0u) return;  // pass 3 left each word its own place

    uint first;
    word_of_brick(brick, 0u, first);
    float scale = float(SORT_BUCKETS) / float(most + 1u);  // bucket = work * 16 / (most + 1) < 16
    uvec4 counters = uvec4(0u);
    for (uint local = 0u; local < WORDS_PER_BRICK; ++local) counters += bucket_one(bucket_of(id_in_brick(first, local), scale));
    // Exclusive prefix sums of the byte counters: within a uint by a multiply, then across the four.
    uvec4 sums = (counters * 0x01010101u) >> 24;
    uvec4 before = uvec4(0u, sums.x, sums.x + sums.y, sums.x + sums.y + sums.z);
    uvec4 starts = counters * 0x01010100u + before * 0x01010101u;
    for (uint local = 0u; local < WORDS_PER_BRICK; ++local) {  // word `local` takes the next place of its bucket
        uint b = bucket_of(id_in_brick(first, local), scale);
        uint place = id_in_brick(first, (pick(starts, b >> 2) >> (8u * (b & 3u))) & 255u);
        starts += bucket_one(b);
        uvec4 counts = imageLoad(u_word_counts, word_texel(place));
        imageStore(u_word_counts, word_texel(place), counts_with_taken(counts, local));
    }
}
