// The tetrahedra's vertex jobs (vertex_jobs.glsl says where they live): mt_triangles.comp (pass 7)
// writes each vertex's edge's start sample (i, j, k) and kind as the uvec2 (i | j << 16, k << 3 | kind),
// and mt_vertices.comp (pass 8) reads it back through job_start() and job_step(), as
// cells_vertices.glsl asks of every kind.  Always the sample, never the word id that the cubes' jobs
// fall back to on large grids: pass 8 then needs no division, for 8 bytes per vertex instead of 4.
// (i and j fit 16 bits: plan_extractor keeps them below GL_MAX_3D_TEXTURE_SIZE, at most 16384 on
// the GLs we know.)
#include "mc_common.glsl"
#include "vertex_jobs.glsl"
uvec2 mt_job(ivec3 start, uint kind) { return uvec2(uint(start.x) | (uint(start.y) << 16), (uint(start.z) << 3) | kind); }
ivec3 job_start(uvec2 job) { return ivec3(int(job.x & 0xFFFFu), int(job.x >> 16), int(job.y >> 3)); }
ivec3 job_step(uvec2 job) {  // kind_dir() of the job's kind (mt_cells.glsl), as a step
    uint dir = (0x7653421u >> (4u * (job.y & 7u))) & 7u;
    return ivec3(int(dir & 1u), int((dir >> 1) & 1u), int(dir >> 2));
}
