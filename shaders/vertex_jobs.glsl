// Vertex jobs: the triangle pass (mc_triangles.comp, mt_triangles.comp) writes each vertex's job,
// the edge it lies on, into texel `vertex` of an image 2^u_job_shift texels wide (app/extractor.py
// grows it with the mesh), and the vertex pass (mc_vertices.comp, mt_vertices.comp) reads it back.  Not into the vertex's own slot of
// the vertex buffer, as they once did: on llvmpipe an SSBO load goes lane by lane and an imageLoad
// is one gather, and reading the job back from the SSBO took about a third of the vertex pass.
uniform uint u_job_shift;

ivec2 job_texel(uint vertex) { return ivec2(vertex & ((1u << u_job_shift) - 1u), vertex >> u_job_shift); }
