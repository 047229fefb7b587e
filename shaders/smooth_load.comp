#version 430
// Smoothing pass 3 of 5, one invocation per vertex: the mesh's positions into index units, with
// the axes the vertex may move along (not those where it lies on the volume's border); its ring's
// slots (first, last + 1) in the neighbour list; and the field's curvature around where it starts
// (smooth_step.comp corrects the level by it).  Each is stored in an image: smooth_step loads them
// every iteration, and an imageLoad costs llvmpipe a fraction of an SSBO load.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

struct Vertex { vec4 position_value; vec4 normal; };
layout(std430, binding = 8) readonly buffer Vertices { Vertex vertices[]; };
layout(rgba32f, binding = 1) writeonly uniform image2D u_positions;
layout(rg32ui, binding = 4) writeonly uniform uimage2D u_rings;
layout(rgba32f, binding = 5) writeonly uniform image2D u_curvatures;

// Per axis, the mean second difference along the 4 grid lines through x's cell along that axis:
// (f[s] - f[s+1] - f[s+2] + f[s+3]) / 2 per line, s = the cell - 1 moved inward at the border.
// Along axis a (unit vector `along`, the others u and w) from cell c; 0 with fewer than 4 samples.
float axis_curvature(ivec3 c, int a, ivec3 along, ivec3 u, ivec3 w) {
    if (u_dims[a] < 4) return 0.0;
    ivec3 start = c + along * (clamp(c[a] - 1, 0, u_dims[a] - 4) - c[a]);
    float sum = 0.0;
    for (int line = 0; line < 4; line++) {
        ivec3 p = start + (line >> 1) * u + (line & 1) * w;
        sum += (field_at(p) - field_at(p + along)) - (field_at(p + 2 * along) - field_at(p + 3 * along));
    }
    return sum * 0.125;
}

vec3 curvature(vec3 x) {
    ivec3 c = clamp(ivec3(floor(x)), ivec3(0), u_dims - 2);
    ivec3 i = ivec3(1, 0, 0), j = ivec3(0, 1, 0), k = ivec3(0, 0, 1);
    return vec3(axis_curvature(c, 0, i, j, k), axis_curvature(c, 1, j, i, k), axis_curvature(c, 2, k, i, j));
}


void main() {
    uint v = vertex_index();
    if (v >= u_vertex_count) return;
    vec3 x = vertices[v].position_value.xyz / u_spacing;
    bvec3 free = bvec3(uvec3(greaterThan(x, vec3(BORDER))) & uvec3(lessThan(x, vec3(u_dims - 1) - BORDER)));
    uvec3 bits = uvec3(free) * uvec3(1u, 2u, 4u);
    imageStore(u_positions, item_texel(v), vec4(x, float(bits.x | bits.y | bits.z)));
    imageStore(u_rings, item_texel(v), uvec4(v == 0u ? 0u : ends[v - 1u], ends[v], 0u, 0u));
    imageStore(u_curvatures, item_texel(v), vec4(curvature(clamp(x, vec3(0.0), vec3(u_dims - 1))), 0.0));
}
