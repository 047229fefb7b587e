#version 430
// Smoothing pass 3 of 5, one invocation per vertex: the mesh's positions into index units, with
// the axes the vertex may move along (not those where it lies on the volume's border).
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

struct Vertex { vec4 position_value; vec4 normal; };
layout(std430, binding = 8) readonly buffer Vertices { Vertex vertices[]; };
layout(rgba32f, binding = 1) writeonly uniform image2D u_positions;

void main() {
    uint v = vertex_index();
    if (v >= u_vertex_count) return;
    vec3 x = vertices[v].position_value.xyz / u_spacing;
    bvec3 free = bvec3(uvec3(greaterThan(x, vec3(BORDER))) & uvec3(lessThan(x, vec3(u_dims - 1) - BORDER)));
    uvec3 bits = uvec3(free) * uvec3(1u, 2u, 4u);
    imageStore(u_positions, item_texel(v), vec4(x, float(bits.x | bits.y | bits.z)));
}
