// Vertex jobs: the triangle pass (cells_triangles.glsl) writes each vertex's job, the edge it lies on,
// into the vertex's slot of a job buffer, and the vertex pass (cells_vertices.glsl) reads it back; both
// declare the buffer at BLOCK_VERTEX_JOBS (app/core/layout.py) of VERTEX_JOB elements, the cell kind's
// (CellKind.job_components: a uint for cubes, mc_jobs.glsl; a uvec2 for tetrahedra, mt_jobs.glsl).  Like the mesh buffers the
// job buffer is bound a window at a time: a triangle run binds the window that holds its words'
// vertices and writes vertex v at v - u_job_first; a vertex run binds the window of its vertices.
// Not the vertex buffer's own slots, as they once were (a job read from between vertex records was a
// third of the vertex pass), nor a 2-D image, as they were next: an imageStore costs llvmpipe ~6 ns
// a lane, a plain store far less (tetrahedra on noise 256^3: 359 -> 295 ms an extraction).
uniform uint u_job_first;
