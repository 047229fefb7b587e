#version 430
// Smoothing pass 4 of 5, once per iteration, one invocation per vertex: move UMBRELLA_WEIGHT of
// the way to the neighbours' average (along free axes), then NEWTON_STEPS Newton steps on the
// trilinear interpolant toward the level, along the physical gradient, clamped to the 3 cells
// around where the move went.  A projection ending over u_tolerance off the level is discarded.
// NEWTON_STEPS and CONVERGED are #defines from app/reference_smooth.py.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

uniform float u_tolerance;
layout(r32ui, binding = 3) readonly uniform uimage2D u_neighbours;
layout(rgba32f, binding = 1) readonly uniform image2D u_before;
layout(rgba32f, binding = 2) writeonly uniform image2D u_after;

vec3 position_before(uint v) { return imageLoad(u_before, item_texel(v)).xyz; }

void main() {
    uint v = vertex_index();
    if (v >= u_vertex_count) return;
    vec4 here = imageLoad(u_before, item_texel(v));
    vec3 x = here.xyz, free = free_axes(here.w);
    uint first = v == 0u ? 0u : ends[v - 1u], last = ends[v];
    vec3 offset = vec3(0.0);
    for (uint s = first; s < last; s++) offset += position_before(imageLoad(u_neighbours, item_texel(s)).x) - x;
    vec3 y = x;
    if (last > first) y += UMBRELLA_WEIGHT * (offset / float(last - first)) * free;

    vec3 top = vec3(u_dims - 1);
    y = clamp(y, vec3(0.0), top);
    vec3 lo = max(floor(y) - 1.0, vec3(0.0)), hi = min(floor(y) + 2.0, top);
    float r;
    for (int step = 0; ; step++) {  // stops once within CONVERGED of the tolerance, or after NEWTON_STEPS
        vec4 f = trilinear(y);
        r = f.w - u_level;
        if (abs(r) <= CONVERGED * u_tolerance || step == NEWTON_STEPS) break;
        vec3 g = f.xyz / u_spacing * free;
        float gg = dot(g, g);
        if (gg > 0.0) y = clamp(y - (r / gg) * g / u_spacing, lo, hi);
    }
    imageStore(u_after, item_texel(v), abs(r) <= u_tolerance ? vec4(y, here.w) : here);
}
