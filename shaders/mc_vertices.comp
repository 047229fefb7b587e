#version 430
// Pass 6, over active bricks, one invocation per word: a vertex per sign-changing edge the
// word owns, from the word's first vertex on, axis by axis.
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_active_bricks.glsl"

layout(std430, binding = 3) readonly buffer WordCounts { uint word_counts[]; };
layout(std430, binding = 5) readonly buffer WordOffsets { uvec2 word_offsets[]; };  // (vertex, triangle)

struct Vertex { vec4 position_value; vec4 normal; };
layout(std430, binding = 6) writeonly buffer Vertices { Vertex vertices[]; };

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
    uint brick;
    if (!active_brick(brick)) return;
    bool exists;
    ivec3 word = brick_word(brick, exists);
    if (!exists) return;
    uint id = word_id_of(word.x, word.y, word.z);
    if (vertex_total(word_counts[id]) == 0u) return;
    uint next = word_offsets[id].x;

    uvec3 crossing = crossing_masks(word.x, word.y, word.z);
    for (int axis = 0; axis < 3; ++axis) {
        uint bits = crossing[axis];
        while (bits != 0u) {
            int b = findLSB(bits);
            bits &= bits - 1u;
            vertices[next++] = edge_vertex(ivec3(word.x, word.y, 32 * word.z + b), axis);
        }
    }
}
