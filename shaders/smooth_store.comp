#version 430
// Smoothing pass 5 of 5, one invocation per vertex: the smoothed positions back into the mesh,
// with the value there and the outward normal from the field's gradient (central differences at
// the cell's 8 corners, blended trilinearly); where that vanishes the vertex keeps its normal.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

struct Vertex { vec4 position_value; vec4 normal; };
layout(std430, binding = 8) buffer Vertices { Vertex vertices[]; };
layout(rgba32f, binding = 1) readonly uniform image2D u_positions;

vec3 corner_gradient(ivec3 p) {
    ivec3 lo = max(p - 1, ivec3(0)), hi = min(p + 1, u_dims - 1);
    return vec3(field_at(ivec3(hi.x, p.y, p.z)) - field_at(ivec3(lo.x, p.y, p.z)),
                field_at(ivec3(p.x, hi.y, p.z)) - field_at(ivec3(p.x, lo.y, p.z)),
                field_at(ivec3(p.x, p.y, hi.z)) - field_at(ivec3(p.x, p.y, lo.z))) / (vec3(hi - lo) * u_spacing);
}

void main() {
    uint v = vertex_index();
    if (v >= u_vertex_count) return;
    vec3 x = imageLoad(u_positions, item_texel(v)).xyz;
    ivec3 c = clamp(ivec3(floor(x)), ivec3(0), u_dims - 2);
    vec3 f = x - vec3(c);
    vec3 g = vec3(0.0);
    for (int corner = 0; corner < 8; corner++) {
        ivec3 d = ivec3(corner >> 2, (corner >> 1) & 1, corner & 1);
        vec3 w = mix(1.0 - f, f, vec3(d));
        g += (w.x * w.y * w.z) * corner_gradient(c + d);
    }
    float len = length(g);
    vertices[v].position_value = vec4(x * u_spacing, trilinear(x).w * u_sign);
    if (len > 0.0) vertices[v].normal = vec4(-g / len, 0.0);
}
