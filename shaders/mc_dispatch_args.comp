#version 430
// Between passes 1 and 2: turn the active-brick count into indirect dispatch sizes, folded into
// 2-D because one dimension holds at most MAX_GROUPS_PER_DIMENSION work groups.
layout(local_size_x = 1) in;

layout(std430, binding = BLOCK_ACTIVE_BRICKS) readonly buffer ActiveBricks { uint active_count; uint active_bricks[]; };
// Two sets: one work group per active brick, and one invocation per active brick (GROUP_SIZE a group).
layout(std430, binding = BLOCK_DISPATCH_ARGS) writeonly buffer DispatchArgs { uint groups[6]; };

// As evenly as gpu_programs.dispatch_groups folds (x * y - count < y): empty groups are not free on
// llvmpipe, and count = 65,536 as 65,535 x 2 would add ~65,000 of them.
void fold(uint count, uint at) {
    uint y = (count + uint(MAX_GROUPS_PER_DIMENSION) - 1u) / uint(MAX_GROUPS_PER_DIMENSION);
    uint x = y == 0u ? 0u : (count + y - 1u) / y;
    groups[at] = max(x, 1u);
    groups[at + 1u] = y;
    groups[at + 2u] = 1u;
}

void main() {
    fold(active_count, 0u);
    fold((active_count + uint(GROUP_SIZE) - 1u) / uint(GROUP_SIZE), 3u);
}
