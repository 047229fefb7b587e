// The tetrahedra's vertex jobs: mt_triangles.comp (pass 7) writes each vertex's job, (owning word
// id, kind << 5 | bit), into texel `vertex` of an rg32ui image, 2^u_job_shift texels wide, and
// mt_vertices.comp (pass 8) reads it back.  Not into the vertex's own slot of the vertex buffer,
// as the cubes' passes do: on llvmpipe reading the job back from that SSBO took about a third
// of the vertex pass (an SSBO load goes lane by lane, an imageLoad is one gather), for 8 bytes
// per vertex of scratch (app/tetra_extractor.py grows the image with the mesh).
uniform uint u_job_shift;

ivec2 job_texel(uint vertex) { return ivec2(vertex & ((1u << u_job_shift) - 1u), vertex >> u_job_shift); }
