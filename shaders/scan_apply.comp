#version 430
// Exclusive scan, step 2 of 2: scan each block of SCAN_BLOCK elements in place and add
// the block's offset (the scanned block sums), when there is more than one block.
layout(local_size_x = SCAN_GROUP) in;

layout(std430, binding = BLOCK_SCAN_DATA) buffer Data { uint data[]; };
layout(std430, binding = BLOCK_SCAN_SUMS) readonly buffer BlockOffsets { uint block_offsets[]; };
uniform uint u_count;
uniform uint u_blocks;
uniform bool u_has_offsets;

shared uint partial[SCAN_GROUP];

void main() {
    uint block = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (block >= u_blocks) return;
    uint lid = gl_LocalInvocationID.x;
    uint first = block * uint(SCAN_BLOCK) + lid * uint(SCAN_ITEMS_PER_INVOCATION);
    uint values[SCAN_ITEMS_PER_INVOCATION];
    uint sum = 0u;
    for (uint q = 0u; q < uint(SCAN_ITEMS_PER_INVOCATION); ++q) {
        values[q] = first + q < u_count ? data[first + q] : 0u;
        sum += values[q];
    }
    partial[lid] = sum;
    barrier();
    for (uint offset = 1u; offset < uint(SCAN_GROUP); offset <<= 1) {  // Hillis-Steele inclusive scan of thread sums
        uint add = lid >= offset ? partial[lid - offset] : 0u;
        barrier();
        partial[lid] += add;
        barrier();
    }
    uint running = partial[lid] - sum + (u_has_offsets ? block_offsets[block] : 0u);
    for (uint q = 0u; q < uint(SCAN_ITEMS_PER_INVOCATION); ++q) {
        if (first + q < u_count) data[first + q] = running;
        running += values[q];
    }
}
