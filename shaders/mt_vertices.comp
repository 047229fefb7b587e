#version 430
// Tetrahedra pass 8, one invocation per vertex: its position, value and outward normal from the job
// that mt_triangles.comp left for it (mt_jobs.glsl), as mc_vertices.comp does for an axis edge.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_common.glsl"
#include "mt_jobs.glsl"

// The window of the vertex buffer (and of the job buffer) bound below: its vertex count.
uniform uint u_vertex_count;

struct Vertex { vec4 position_value; vec4 normal; };
layout(std430, binding = BLOCK_MESH_VERTICES) writeonly buffer Vertices { Vertex vertices[]; };
layout(std430, binding = BLOCK_VERTEX_JOBS) readonly buffer VertexJobs { uvec2 vertex_jobs[]; };  // this run's window

// Central differences, one-sided at the border, in physical units (as mc_vertices.comp).
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
    uvec2 job = vertex_jobs[index];
    uint dir = (0x7653421u >> (4u * mt_job_kind(job))) & 7u;  // mt_common.glsl's kind_dir()
    ivec3 step = ivec3(int(dir & 1u), int((dir >> 1) & 1u), int(dir >> 2));
    ivec3 p0 = mt_job_start(job);
    float v0 = field_at(p0), v1 = field_at(p0 + step);
    float t = clamp((u_level - v0) / (v1 - v0), EDGE_MARGIN, 1.0 - EDGE_MARGIN);

    vec3 g0 = gradient_at(p0), g1 = gradient_at(p0 + step);
    vec3 g = g0 + t * (g1 - g0);
    float len = length(g);
    // Out is downhill; a flat field points along the edge, from its inside end to its outside end.
    vec3 normal = len > 0.0 ? -g / len : (v0 >= u_level ? 1.0 : -1.0) * normalize(vec3(step) * u_spacing);

    Vertex v;
    v.position_value = vec4((vec3(p0) + t * vec3(step)) * u_spacing, (v0 + t * (v1 - v0)) * u_sign);
    v.normal = vec4(normal, 0.0);
    vertices[index] = v;
}
