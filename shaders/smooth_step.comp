#version 430
// Smoothing pass 4 of 5, once per iteration, one invocation per vertex: move UMBRELLA_WEIGHT of
// the way to the neighbours' average (along free axes), then NEWTON_STEPS Newton steps on the
// trilinear interpolant toward the level, along the physical gradient, clamped to the 3 cells
// around where the move went.  A projection ending over u_tolerance off the level is discarded.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

uniform float u_tolerance;
layout(std430, binding = 3) readonly buffer Neighbours { uint neighbours[]; };
layout(std430, binding = 4) readonly buffer Before { vec4 before[]; };
layout(std430, binding = 5) writeonly buffer After { vec4 after[]; };

void main() {
    uint v = vertex_index();
    if (v >= u_vertex_count) return;
    vec4 here = before[v];
    vec3 x = here.xyz, free = free_axes(here.w);
    uint first = v == 0u ? 0u : ends[v - 1u], last = ends[v];
    vec3 offset = vec3(0.0);
    for (uint s = first; s < last; s++) offset += before[neighbours[s]].xyz - x;
    vec3 y = x;
    if (last > first) y += UMBRELLA_WEIGHT * (offset / float(last - first)) * free;

    vec3 top = vec3(u_dims - 1);
    y = clamp(y, vec3(0.0), top);
    vec3 lo = max(floor(y) - 1.0, vec3(0.0)), hi = min(floor(y) + 2.0, top);
    for (int step = 0; step < NEWTON_STEPS; step++) {
        vec4 f = trilinear(y);
        vec3 g = f.xyz / u_spacing * free;
        float gg = dot(g, g);
        if (gg > 0.0) y = clamp(y - ((f.w - u_level) / gg) * g / u_spacing, lo, hi);
    }
    after[v] = abs(trilinear(y).w - u_level) <= u_tolerance ? vec4(y, here.w) : here;
}
