#version 430
// Exclusive scan, step 1 of 2: the sum of each block of SCAN_BLOCK elements.
layout(local_size_x = SCAN_GROUP) in;

layout(std430, binding = BLOCK_SCAN_DATA) readonly buffer Data { uint data[]; };
layout(std430, binding = BLOCK_SCAN_SUMS) writeonly buffer BlockSums { uint block_sums[]; };
uniform uint u_count;
uniform uint u_blocks;

shared uint partial[SCAN_GROUP];

void main() {
    uint block = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (block >= u_blocks) return;  // uniform across the group: no barrier is skipped by half of it
    uint lid = gl_LocalInvocationID.x;
    uint first = block * uint(SCAN_BLOCK) + lid * uint(SCAN_ITEMS_PER_INVOCATION);
    uint sum = 0u;
    for (uint q = 0u; q < uint(SCAN_ITEMS_PER_INVOCATION); ++q) {
        if (first + q < u_count) sum += data[first + q];
    }
    partial[lid] = sum;
    barrier();
    for (uint stride = uint(SCAN_GROUP) / 2u; stride > 0u; stride >>= 1) {
        if (lid < stride) partial[lid] += partial[lid + stride];
        barrier();
    }
    if (lid == 0u) block_sums[block] = partial[0];
}
