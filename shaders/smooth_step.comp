#version 430
// Smoothing pass 4 of 5, once per iteration, one invocation per vertex: move UMBRELLA_WEIGHT of
// the way to the neighbours' average (along free axes), then NEWTON_STEPS Newton steps on the
// trilinear interpolant toward the level, along the physical gradient, clamped to the 3 cells
// around where the move went.  The level is corrected by the interpolant's own error estimate
// E = sum t(1 - t)/2 k (k: second differences around the cell, taken once per projection; E capped
// at +-u_correction; see app/reference_smooth.py).  A projection ending over u_tolerance off the
// corrected level is discarded.
// NEWTON_STEPS and CONVERGED are #defines from app/reference_smooth.py.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

uniform float u_tolerance;
uniform float u_correction;
layout(r32ui, binding = 3) readonly uniform uimage2D u_neighbours;
layout(rgba32f, binding = 1) readonly uniform image2D u_before;
layout(rgba32f, binding = 2) writeonly uniform image2D u_after;

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

// F(x) - E(x) - level and its gradient (index units): vec4(gradient, residual).
vec4 corrected(vec3 x, vec3 k) {
    vec4 f = trilinear(x);
    vec3 t = x - vec3(clamp(floor(x), vec3(0.0), vec3(u_dims - 2)));
    float error = dot(t * (1.0 - t) * 0.5, k);
    vec3 slope = abs(error) <= u_correction ? (0.5 - t) * k : vec3(0.0);
    return vec4(f.xyz - slope, f.w - clamp(error, -u_correction, u_correction) - u_level);
}

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
    vec3 k = curvature(y);
    float r;
    for (int step = 0; ; step++) {  // stops once within CONVERGED of the tolerance, or after NEWTON_STEPS
        vec4 f = corrected(y, k);
        r = f.w;
        if (abs(r) <= CONVERGED * u_tolerance || step == NEWTON_STEPS) break;
        vec3 g = f.xyz / u_spacing * free;
        float gg = dot(g, g);
        if (gg > 0.0) y = clamp(y - (r / gg) * g / u_spacing, lo, hi);
    }
    imageStore(u_after, item_texel(v), abs(r) <= u_tolerance ? vec4(y, here.w) : here);
}
