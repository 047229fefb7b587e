#version 430
// Smoothing pass 6 of 6, one invocation per vertex: the smoothed positions back into the mesh,
// with the value there and the outward normal from the field's gradient (central differences at
// the cell's 8 corners, blended trilinearly); where that vanishes the vertex keeps its normal.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

struct Vertex { vec4 position_value; vec4 normal; };
layout(std430, binding = BLOCK_MESH_VERTICES) buffer Vertices { Vertex vertices[]; };
layout(rgba32f, binding = UNIT_POSITIONS) readonly uniform image2D u_positions;

// Central differences (one-sided at the border) at corner d of cell c, physical units.  Along each
// axis one neighbour is another corner of the cell, already in s: only the other is loaded, so the
// 8 corners take 8 + 24 loads instead of 8 x 6.
vec3 corner_gradient(ivec3 c, mat2x4 s, ivec3 d) {
    ivec3 p = c + d, far = clamp(p + 2 * d - 1, ivec3(0), u_dims - 1);  // outward, away from the cell
    vec3 outer = vec3(field_at(ivec3(far.x, p.y, p.z)), field_at(ivec3(p.x, far.y, p.z)),
                      field_at(ivec3(p.x, p.y, far.z)));
    vec3 inner = vec3(corner_sample(s, d ^ ivec3(1, 0, 0)), corner_sample(s, d ^ ivec3(0, 1, 0)),
                      corner_sample(s, d ^ ivec3(0, 0, 1)));
    bvec3 up = equal(d, ivec3(1));  // the outer neighbour is the high end
    vec3 rise = mix(inner - outer, outer - inner, up);
    return rise / (vec3(abs(far - (p - (2 * d - 1)))) * u_spacing);
}

void main() {
    uint v = vertex_index();
    if (v >= u_vertex_count) return;
    vec3 x = imageLoad(u_positions, item_texel(v)).xyz;
    ivec3 c = cell_of(x);
    mat2x4 s = cell_samples(c);
    vec3 f = x - vec3(c);
    vec3 g = vec3(0.0);
    for (int corner = 0; corner < 8; corner++) {
        ivec3 d = ivec3(corner >> 2, (corner >> 1) & 1, corner & 1);
        vec3 w = mix(1.0 - f, f, vec3(d));
        g += (w.x * w.y * w.z) * corner_gradient(c, s, d);
    }
    float len = length(g);
    vertices[v].position_value = vec4(x * u_spacing, trilinear_in(x, c, s).w * u_sign);
    if (len > 0.0) vertices[v].normal = vec4(-g / len, 0.0);
}
