#version 430
// Pass 4: one vertex per sign-changing edge, at the word's scanned offset, axis by axis.
layout(local_size_x = 64) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"

layout(std430, binding = 1) readonly buffer VertexOffsets { uint vertex_offsets[]; };

struct Vertex { vec4 position_value; vec4 normal; };
layout(std430, binding = 5) writeonly buffer Vertices { Vertex vertices[]; };

vec3 gradient_at(ivec3 p) {  // central differences, one-sided at the border, physical units
    vec3 g;
    for (int a = 0; a < 3; ++a) {
        ivec3 lo = p, hi = p;
        lo[a] = max(p[a] - 1, 0);
        hi[a] = min(p[a] + 1, u_dims[a] - 1);
        g[a] = (field_at(hi) - field_at(lo)) / (float(hi[a] - lo[a]) * u_spacing[a]);
    }
    return g;
}

Vertex edge_vertex(ivec3 p0, int axis) {
    ivec3 step = ivec3(0);
    step[axis] = 1;
    ivec3 p1 = p0 + step;
    float v0 = field_at(p0), v1 = field_at(p1);
    float t = clamp((u_level - v0) / (v1 - v0), EDGE_MARGIN, 1.0 - EDGE_MARGIN);

    vec3 g0 = gradient_at(p0), g1 = gradient_at(p1);
    vec3 g = g0 + t * (g1 - g0);
    float len = length(g);
    // The field grows into the object, so out is downhill; a flat field points along the edge outwards.
    vec3 normal = len > 0.0 ? -g / len : (v0 >= u_level ? 1.0 : -1.0) * vec3(step);

    Vertex v;
    v.position_value = vec4((vec3(p0) + t * vec3(step)) * u_spacing, (v0 + t * (v1 - v0)) * u_sign);
    v.normal = vec4(normal, 0.0);
    return v;
}

void main() {
    uint word_id = invocation_index();
    if (word_id >= u_word_count) return;
    uint next = vertex_offsets[word_id];
    if (vertex_offsets[word_id + 1u] == next) return;
    ivec3 p = word_origin(word_id);
    uvec3 crossing = crossing_masks(p.x, p.y, p.z / 32);
    for (int axis = 0; axis < 3; ++axis) {
        uint bits = crossing[axis];
        while (bits != 0u) {
            int b = findLSB(bits);
            bits &= bits - 1u;
            vertices[next++] = edge_vertex(ivec3(p.x, p.y, p.z + b), axis);
        }
    }
}
