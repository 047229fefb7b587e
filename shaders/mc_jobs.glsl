// The cubes' vertex jobs (vertex_jobs.glsl says where they live): mc_triangles.comp (pass 7) writes
// each vertex's job, the edge it lies on, and mc_vertices.comp (pass 8) reads it back through
// job_start() and job_step(), as cells_vertices.glsl asks of every kind.
//
// A job is the edge's start sample (i, j, k) and axis in one uint, ((i << bits of j | j) << bits of
// k | k) << 2 | axis, decoded by shifts (core/layout.py's job_coordinate_bits: u_job_bits = the bits
// of j and of k).  A grid too large for that (JOB_COORDINATES undefined) packs the owning word's id,
// the axis and the bit of the start sample instead (word id << 7 | axis << 5 | bit: at most 2^25
// words, core/layout.py's MAX_WORDS), which costs two divisions to decode: a fifth of the vertex pass
// on the MNI T1.
#include "mc_common.glsl"
#include "vertex_jobs.glsl"
#ifdef JOB_COORDINATES
uniform uvec2 u_job_bits;
// The jobs of word (i, j, w) (grid id word_id) are job_base(...) | vertex_job_bits(axis, bit).
uint job_base(ivec3 word, uint word_id) {
    return ((((uint(word.x) << u_job_bits.x) | uint(word.y)) << u_job_bits.y) | uint(WORD_BITS * word.z)) << 2;
}
uint vertex_job_bits(uint axis, uint bit) { return (bit << 2) | axis; }
ivec3 job_start(uint job) {
    uint ij = job >> (2u + u_job_bits.y);
    return ivec3(ij >> u_job_bits.x, ij & ((1u << u_job_bits.x) - 1u), (job >> 2) & ((1u << u_job_bits.y) - 1u));
}
int job_axis(uint job) { return int(job & 3u); }
#else
uint job_base(ivec3 word, uint word_id) { return word_id << 7; }
uint vertex_job_bits(uint axis, uint bit) { return (axis << 5) | bit; }
ivec3 job_start(uint job) {
    ivec3 word = word_of_id(job >> 7);
    return ivec3(word.xy, word.z * WORD_BITS + int(job & uint(WORD_BITS - 1)));
}
int job_axis(uint job) { return int((job >> 5) & 3u); }
#endif
ivec3 job_step(uint job) { return ivec3(equal(ivec3(job_axis(job)), ivec3(0, 1, 2))); }
