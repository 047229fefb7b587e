// What pass 7 (cells_triangles.glsl) binds, for it and the kind's functions that name vertices.
#include "triangle_runs.glsl"
layout(WORD_COUNTS_FORMAT, binding = UNIT_WORD_COUNTS) readonly uniform uimage2D u_word_counts;
// (first vertex, first triangle[, first own vertex: OWN_VERTICES])
layout(WORD_OFFSETS_FORMAT, binding = UNIT_WORD_OFFSETS) readonly uniform uimage2D u_word_offsets;
layout(std430, binding = BLOCK_MESH_INDICES) writeonly buffer Indices { uint indices[]; };
layout(std430, binding = BLOCK_VERTEX_JOBS) writeonly buffer VertexJobs { VERTEX_JOB vertex_jobs[]; };
