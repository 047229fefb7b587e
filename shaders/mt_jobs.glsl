// The tetrahedra's vertex jobs: mt_triangles.comp (pass 7) writes each vertex's job, its edge's
// start sample (i, j, k) and kind as (i | j << 16, k << 3 | kind), into texel `vertex` of an rg32ui
// image, 2^u_job_shift texels wide, and mt_vertices.comp (pass 8) reads it back.  The sample, not
// the word id that the cubes' jobs hold: pass 8 then needs no division.  (i and j fit 16 bits:
// plan_extractor keeps them below GL_MAX_3D_TEXTURE_SIZE, which is at most 16384 on the GLs we know.)  Not into the vertex's own slot of the vertex buffer,
// as the cubes' passes do: on llvmpipe reading the job back from that SSBO took about a third
// of the vertex pass (an SSBO load goes lane by lane, an imageLoad is one gather), for 8 bytes
// per vertex of scratch (app/tetra_extractor.py grows the image with the mesh).
uniform uint u_job_shift;

ivec2 job_texel(uint vertex) { return ivec2(vertex & ((1u << u_job_shift) - 1u), vertex >> u_job_shift); }
uvec2 mt_job(ivec3 start, uint kind) { return uvec2(uint(start.x) | (uint(start.y) << 16), (uint(start.z) << 3) | kind); }
ivec3 mt_job_start(uvec2 job) { return ivec3(int(job.x & 0xFFFFu), int(job.x >> 16), int(job.y >> 3)); }
uint mt_job_kind(uvec2 job) { return job.y & 7u; }
