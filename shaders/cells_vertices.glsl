// Pass 8, one invocation per vertex, for any cell kind: its position, value and outward normal, from
// the job that pass 7 left for it (vertex_jobs.glsl).  The .comp includes, before this, the kind's
// jobs (mc_jobs.glsl, mt_jobs.glsl: job_start() and job_step() of a VERTEX_JOB, the edge's start
// sample and its 0/1 step) and defines flat_normal(step): the direction, from the edge's inside end
// to its outside end, a vertex on a flat field points in.

// The window of the vertex buffer (and of the job buffer) bound below: its vertex count.
uniform uint u_vertex_count;
layout(std430, binding = BLOCK_VERTEX_JOBS) readonly buffer VertexJobs { VERTEX_JOB vertex_jobs[]; };  // this run's window

struct Vertex { vec4 position_value; vec4 normal; };
layout(std430, binding = BLOCK_MESH_VERTICES) writeonly buffer Vertices { Vertex vertices[]; };

// Central differences, one-sided at the border, in physical units.  Written per axis without
// indexing vectors by a variable: llvmpipe turns such indexing into scratch-memory traffic.
vec3 gradient_at(ivec3 p) {
    ivec3 lo = max(p - 1, ivec3(0)), hi = min(p + 1, u_dims - 1);
    vec3 rise = vec3(field_at(ivec3(hi.x, p.y, p.z)) - field_at(ivec3(lo.x, p.y, p.z)),
                     field_at(ivec3(p.x, hi.y, p.z)) - field_at(ivec3(p.x, lo.y, p.z)),
                     field_at(ivec3(p.x, p.y, hi.z)) - field_at(ivec3(p.x, p.y, lo.z)));
    return rise / (vec3(hi - lo) * u_spacing);
}

void main() {
    uint index = linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
    if (index >= u_vertex_count) return;
    VERTEX_JOB job = vertex_jobs[index];
    ivec3 p0 = job_start(job), step = job_step(job);
    ivec3 p1 = p0 + step;
    float v0 = field_at(p0), v1 = field_at(p1);
    float t = clamp((u_level - v0) / (v1 - v0), EDGE_MARGIN, 1.0 - EDGE_MARGIN);

    vec3 g0 = gradient_at(p0), g1 = gradient_at(p1);
    vec3 g = g0 + t * (g1 - g0);
    float len = length(g);
    // The field grows into the object, so out is downhill.
    vec3 normal = len > 0.0 ? -g / len : (v0 >= u_level ? 1.0 : -1.0) * flat_normal(step);

    Vertex v;
    v.position_value = vec4((vec3(p0) + t * vec3(step)) * u_spacing, (v0 + t * (v1 - v0)) * u_sign);
    v.normal = vec4(normal, 0.0);
    vertices[index] = v;
}
