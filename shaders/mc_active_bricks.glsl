// Passes dispatched indirectly over the active bricks: those whose value range the level cuts,
// listed by mc_bricks.comp (pass 1).
// No pass here uses barrier(): on llvmpipe a work group with barriers runs its invocations as
// coroutines and costs two to four times as much, so per-brick sums and offsets are serial loops
// in one invocation per brick (cells_brick_sums.glsl, cells_word_offsets.glsl).
layout(std430, binding = BLOCK_ACTIVE_BRICKS) readonly buffer ActiveBricks { uint active_count; uint active_bricks[]; };

// The brick of this work group (one invocation per word), or false past the end of the list.
bool active_brick(out uint brick) {
    uint slot = linear_group();
    if (slot >= active_count) return false;
    brick = active_bricks[slot];
    return true;
}

// This work group's brick and this invocation's word (i, j, w) in it (one invocation per word), or
// false past the end of the list or outside the grid.
bool active_word(out uint brick, out ivec3 word) {
    if (!active_brick(brick)) return false;
    bool exists;
    word = brick_word(brick, exists);
    return exists;
}

// The brick of this invocation (one invocation per brick), or false past the end of the list.
bool active_brick_of_invocation(out uint brick) {
    uint slot = linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
    if (slot >= active_count) return false;
    brick = active_bricks[slot];
    return true;
}

// The grid word id of word `local` (0 .. WORDS_PER_BRICK-1) of `brick`, or false outside the grid.
bool word_of_brick(uint brick, uint local, out uint word_id) {
    ivec3 word = brick_origin(brick) + ivec3(int(local) / BRICK_J, int(local) % BRICK_J, 0);
    word_id = word_id_of(word.x, word.y, word.z);
    return word.x < u_dims.x && word.y < u_dims.y;
}
