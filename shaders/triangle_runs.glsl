// The triangle pass's runs (cells_triangles.glsl; isoscope.gpu.passes): a mesh larger
// than one storage block is written a window of the index buffer at a time, one run per window,
// and each word's invocation works only in the runs its triangles meet.  Each word writes its
// vertices' jobs (vertex_jobs.glsl) in just one run, into the job window bound for it: the one
// whose triangle slots [u_job_slots.x, u_job_slots.y) hold the word's first triangle slot (the last
// run's end is 2^32 - 1, so a word with no triangles at the very end has a run too).  Not a run per
// window of the vertex buffer as well: those runs did nothing but jobs, at the cost of a whole pass.
// Each of several runs takes only its own bricks (isoscope.gpu.passes.run_dispatches, in the active
// list's place), so the words that leave at once are those that straddle a window's ends.
uniform uvec2 u_job_slots;
uniform uvec2 u_triangle_window;  // the (first, count) of the triangles bound in this run
bool writes_jobs(uint first_triangle) { return first_triangle - u_job_slots.x < u_job_slots.y - u_job_slots.x; }

// Whether triangles first .. first + count - 1 meet this run's window.
bool meets_triangle_window(uint first, uint count) {
    return count > 0u && first < u_triangle_window.x + u_triangle_window.y && u_triangle_window.x < first + count;
}
