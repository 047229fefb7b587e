#version 430
// Once per volume, step 2 of 2, one invocation per brick: the value range of every sample the
// brick's words' edges and cells touch: its rows plus one more row along axes 0 and 1.
// A level outside this range cannot cut the brick, whatever the level before it was.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_common.glsl"

layout(std430, binding = BLOCK_ROW_RANGES) readonly buffer RowRanges { vec2 row_ranges[]; };
layout(std430, binding = BLOCK_BRICK_RANGES) writeonly buffer BrickRanges { vec2 brick_ranges[]; };

void main() {
    uint brick = linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
    if (brick >= u_brick_count) return;
    ivec3 origin = brick_origin(brick);
    vec2 range = vec2(1.0 / 0.0, -1.0 / 0.0);
    for (int i = origin.x; i <= min(origin.x + BRICK_I, u_dims.x - 1); ++i) {
        for (int j = origin.y; j <= min(origin.y + BRICK_J, u_dims.y - 1); ++j) {
            vec2 r = row_ranges[word_id_of(i, j, origin.z)];
            range = vec2(min(range.x, r.x), max(range.y, r.y));
        }
    }
    brick_ranges[brick] = range;
}
