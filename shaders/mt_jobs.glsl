// The tetrahedra's vertex jobs (vertex_jobs.glsl says where they live): mt_triangles.comp (pass 7)
// writes each vertex's edge's start sample (i, j, k) and kind as (i | j << 16, k << 3 | kind) into an
// rg32ui image, and mt_vertices.comp (pass 8) reads it back.  The sample, not the word id that the
// cubes' jobs hold: pass 8 then needs no division, for 8 bytes per vertex instead of 4.  (i and j fit
// 16 bits: plan_extractor keeps them below GL_MAX_3D_TEXTURE_SIZE, at most 16384 on the GLs we know.)
#include "vertex_jobs.glsl"
uvec2 mt_job(ivec3 start, uint kind) { return uvec2(uint(start.x) | (uint(start.y) << 16), (uint(start.z) << 3) | kind); }
ivec3 mt_job_start(uvec2 job) { return ivec3(int(job.x & 0xFFFFu), int(job.x >> 16), int(job.y >> 3)); }
uint mt_job_kind(uvec2 job) { return job.y & 7u; }
