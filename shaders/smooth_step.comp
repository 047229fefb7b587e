#version 430
// Smoothing pass 4 of 6, once per iteration, one invocation per vertex: propose moving UMBRELLA_WEIGHT of
// the way to the neighbours' average (along free axes), then NEWTON_STEPS Newton steps on the
// trilinear interpolant toward the level, along the physical gradient, clamped to the 3 cells
// around where the move went.  The level is corrected by the interpolant's own error estimate
// E = sum t(1 - t)/2 k (k: second differences around the vertex's first cell, from smooth_load; E
// capped at +-u_correction; see isoscope.cpu.smooth).  A projection ending over u_tolerance off
// the corrected level is discarded.  The proposal goes to u_after, and smooth_keep.comp keeps it or
// not.  Per vertex it loads its position, ring and curvature from images, and per neighbour an index
// and a position: no SSBO loads at all.
// NEWTON_STEPS and CONVERGED are #defines from isoscope.cpu.smooth.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

uniform float u_tolerance;
uniform float u_correction;
layout(rg32ui, binding = UNIT_NEIGHBOURS) readonly uniform uimage2D u_neighbours;
layout(rg32ui, binding = UNIT_RINGS) readonly uniform uimage2D u_rings;
layout(rgba32f, binding = UNIT_CURVATURES) readonly uniform image2D u_curvatures;
layout(rgba32f, binding = UNIT_POSITIONS) readonly uniform image2D u_before;
layout(rgba32f, binding = UNIT_MOVED) writeonly uniform image2D u_after;

// F(x) - E(x) - level and its gradient (index units): vec4(gradient, residual); x in cell c, whose
// samples are s.
vec4 corrected(vec3 x, ivec3 c, mat2x4 s, vec3 k) {
    vec4 f = trilinear_in(x, c, s);
    vec3 t = x - vec3(c);
    float error = dot(t * (1.0 - t) * 0.5, k);
    // A select, not `if (...) f.xyz -= ...`: that form gave other results on llvmpipe (Newton failed on
    // ~16% of the vertices of a noise volume, the numpy mirror on none).
    vec3 slope = abs(error) <= u_correction ? (0.5 - t) * k : vec3(0.0);
    return vec4(f.xyz - slope, f.w - clamp(error, -u_correction, u_correction) - u_level);
}

vec3 position_before(uint v) { return imageLoad(u_before, item_texel(v)).xyz; }

void main() {
    uint v = vertex_index();
    if (v >= u_vertex_count) return;
    vec4 here = imageLoad(u_before, item_texel(v));
    vec3 x = here.xyz, free = free_axes(here.w);
    uvec2 ring = imageLoad(u_rings, item_texel(v)).xy;
    uint first = ring.x, last = ring.y;
    vec3 offset = vec3(0.0);
    for (uint s = first; s < last; s++) offset += position_before(imageLoad(u_neighbours, item_texel(s)).x) - x;
    vec3 y = x;
    if (last > first) y += UMBRELLA_WEIGHT * (offset / float(last - first)) * free;

    vec3 top = vec3(u_dims - 1);
    y = clamp(y, vec3(0.0), top);
    vec3 lo = max(floor(y) - 1.0, vec3(0.0)), hi = min(floor(y) + 2.0, top);
    vec3 k = imageLoad(u_curvatures, item_texel(v)).xyz;
    float r;
    // A Newton step seldom leaves its cell: the cell's 8 samples are loaded again only when it does.
    ivec3 c = cell_of(y);
    mat2x4 samples = cell_samples(c);
    for (int step = 0; ; step++) {  // stops once within CONVERGED of the tolerance, or after NEWTON_STEPS
        ivec3 now = cell_of(y);
        if (now != c) {
            c = now;
            samples = cell_samples(c);
        }
        vec4 f = corrected(y, c, samples, k);
        r = f.w;
        if (abs(r) <= CONVERGED * u_tolerance || step == NEWTON_STEPS) break;
        vec3 g = f.xyz / u_spacing * free;
        float gg = dot(g, g);
        if (gg > 0.0) y = clamp(y - (r / gg) * g / u_spacing, lo, hi);
    }
    imageStore(u_after, item_texel(v), abs(r) <= u_tolerance ? vec4(y, here.w) : here);
}
