#version 430
// Extended-MC pass 1 of 2 (so far), one invocation per triangle: counts the cells that may hold a
// feature (reference_sharp._candidate_cells), so that a mesh with none is the answer as it is,
// with no read-back.  Triangles of one cell come consecutively (mc_triangles.comp); the first of
// each run sums its run's corner normals and tests whether some corner normal is more than half
// the feature angle from their mean.  The test is loosened by CANDIDATE_SLACK (float rounding
// here against numpy's), so a count of 0 means numpy finds no candidate either.
layout(local_size_x = GROUP_SIZE) in;
#include "emc_common.glsl"

uniform uint u_triangle_count;
uniform float u_cos_half;  // cos of half the feature angle
layout(std430, binding = 5) buffer Count { uint candidates; };
layout(std430, binding = 6) readonly buffer Triangles { uint corners[]; };
layout(std430, binding = 8) readonly buffer Vertices { float vertex_data[]; };

const uint RUN_LIMIT = 16u;  // a cell has at most MAX_TRIANGLES_PER_CELL; longer runs count as candidates

vec3 normal_of(uint v) {
    uint base = v * uint(VERTEX_FLOATS) + 4u;
    return vec3(vertex_data[base], vertex_data[base + 1u], vertex_data[base + 2u]);
}

// reference_sharp.edge_of_vertex's start point: floor along the edge's axis, the grid plane on the others.
ivec3 edge_start(uint v) {
    uint base = v * uint(VERTEX_FLOATS);
    vec3 g = vec3(vertex_data[base], vertex_data[base + 1u], vertex_data[base + 2u]) / u_spacing;
    vec3 nearest = roundEven(g);
    return ivec3(mix(nearest, floor(g), greaterThan(abs(g - nearest), vec3(1e-3))));
}

// reference_sharp.cell_runs: a triangle's cell is the least edge start of its corners per axis.
ivec3 cell_of(uint t) {
    return min(min(edge_start(corners[3u * t]), edge_start(corners[3u * t + 1u])), edge_start(corners[3u * t + 2u]));
}

void main() {
    uint t = item_index();
    if (t >= u_triangle_count) return;
    ivec3 cell = cell_of(t);
    if (t > 0u && cell_of(t - 1u) == cell) return;  // not the first of its run
    vec3 sum = vec3(0.0);
    uint end = t;
    while (end < u_triangle_count && end - t < RUN_LIMIT && (end == t || cell_of(end) == cell)) {
        for (uint c = 0u; c < 3u; c++) sum += normal_of(corners[3u * end + c]);
        end++;
    }
    bool candidate = end - t >= RUN_LIMIT;
    vec3 mean = sum / max(length(sum), 1e-30);
    for (uint f = t; f < end; f++)
        for (uint c = 0u; c < 3u; c++)
            candidate = candidate || dot(normal_of(corners[3u * f + c]), mean) < u_cos_half + CANDIDATE_SLACK;
    if (candidate) atomicAdd(candidates, 1u);
}
