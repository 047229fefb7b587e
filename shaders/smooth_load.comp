#version 430
// Smoothing pass 2 of 6 (after the scan), one invocation per vertex: the mesh's positions into index units, with
// the axes the vertex may move along (not those where it lies on the volume's border); its ring's
// slots (first, last + 1) in the neighbour list; and the field's curvature around where it starts
// (smooth_step.comp corrects the level by it).  Each is stored in an image: smooth_step loads them
// every iteration, and an imageLoad costs llvmpipe a fraction of an SSBO load.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

struct Vertex { vec4 position_value; vec4 normal; };
layout(std430, binding = BLOCK_MESH_VERTICES) readonly buffer Vertices { Vertex vertices[]; };
layout(rgba32f, binding = UNIT_POSITIONS) writeonly uniform image2D u_positions;
layout(rg32ui, binding = UNIT_RINGS) writeonly uniform uimage2D u_rings;
layout(rgba32f, binding = UNIT_CURVATURES) writeonly uniform image2D u_curvatures;

// Per axis, the mean second difference along the 4 grid lines through cell c along that axis, at
// the cell's two ends (isoscope.cpu.smooth's curvature(), in its order of operations): the
// cell's corners come from s, so each line loads only its sample beyond each end.
float axis_curvature(ivec3 c, mat2x4 s, int a, ivec3 along, ivec3 u, ivec3 w) {
    if (u_dims[a] < 3) return 0.0;
    float sum = 0.0;
    for (int line = 0; line < 4; line++) {
        ivec3 d = (line >> 1) * u + (line & 1) * w;
        float f0 = corner_sample(s, d), f1 = corner_sample(s, d + along);
        ivec3 p = c + d;
        float below = field_at(p - along * min(c[a], 1)), above = field_at(p + along * min(u_dims[a] - 1 - c[a], 2));
        sum += c[a] == 0 ? 2.0 * ((f0 - f1) - (f1 - above))
             : c[a] + 2 > u_dims[a] - 1 ? 2.0 * ((below - f0) - (f0 - f1)) : (below - f0) - (f1 - above);
    }
    return sum * 0.125;
}

vec3 curvature(vec3 x) {
    ivec3 c = cell_of(x);
    mat2x4 s = cell_samples(c);
    ivec3 i = ivec3(1, 0, 0), j = ivec3(0, 1, 0), k = ivec3(0, 0, 1);
    return vec3(axis_curvature(c, s, 0, i, j, k), axis_curvature(c, s, 1, j, i, k),
                axis_curvature(c, s, 2, k, i, j));
}

void main() {
    uint v = vertex_index();
    if (v >= u_vertex_count) return;
    vec3 x = vertices[v].position_value.xyz / u_spacing;
    bvec3 free = bvec3(uvec3(greaterThan(x, vec3(BORDER))) & uvec3(lessThan(x, vec3(u_dims - 1) - BORDER)));
    uvec3 bits = uvec3(free) * uvec3(1u, 2u, 4u);
    imageStore(u_positions, item_texel(v), vec4(x, float(bits.x | bits.y | bits.z)));
    imageStore(u_rings, item_texel(v), uvec4(ends[v], ends[v + 1u], 0u, 0u));  // scanned: first slots
    imageStore(u_curvatures, item_texel(v), vec4(curvature(clamp(x, vec3(0.0), vec3(u_dims - 1))), 0.0));
}
