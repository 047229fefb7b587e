#version 430
// Smoothing pass 5 of 6, once per iteration after smooth_step.comp, one invocation per vertex: keep
// the vertex's proposed move only if none of its triangles collapses (isoscope.cpu.smooth's
// keeps_triangles(), in its order of operations).  Each outgoing half-edge v->b names one triangle
// (v, b, c) (c stored next to b by smooth_fill.comp); with v moved, b and c each where it was or
// where its own move would take it (all 4 combinations: every vertex moves at once), the doubled
// area |edge x edge|^2 must stay >= min(what it was, FLOOR_SQUARED).  Whichever moves are kept,
// every triangle then is one that was checked, so none falls below min(its first area, MIN_AREA).
// FLOOR_SQUARED is a #define from isoscope.cpu.smooth.
layout(local_size_x = GROUP_SIZE) in;
#include "smooth_common.glsl"

layout(rg32ui, binding = UNIT_NEIGHBOURS) readonly uniform uimage2D u_neighbours;
layout(rg32ui, binding = UNIT_RINGS) readonly uniform uimage2D u_rings;
layout(rgba32f, binding = UNIT_POSITIONS) readonly uniform image2D u_before;
layout(rgba32f, binding = UNIT_MOVED) readonly uniform image2D u_moved;
layout(rgba32f, binding = UNIT_NEXT_POSITIONS) writeonly uniform image2D u_after;

bool kept(vec3 before, vec3 after) {
    float old = dot(before, before), now = dot(after, after);
    return now >= min(old, FLOOR_SQUARED);
}

void main() {
    uint v = vertex_index();
    if (v >= u_vertex_count) return;
    vec4 here = imageLoad(u_before, item_texel(v));
    vec4 there = imageLoad(u_moved, item_texel(v));
    uvec2 ring = imageLoad(u_rings, item_texel(v)).xy;
    bool ok = true;
    for (uint s = ring.x; s < ring.y && ok; s++) {
        uvec2 bc = imageLoad(u_neighbours, item_texel(s)).xy;
        vec3 b0 = imageLoad(u_before, item_texel(bc.x)).xyz, b1 = imageLoad(u_moved, item_texel(bc.x)).xyz;
        vec3 c0 = imageLoad(u_before, item_texel(bc.y)).xyz, c1 = imageLoad(u_moved, item_texel(bc.y)).xyz;
        vec3 before = cross(b0 - here.xyz, c0 - here.xyz);
        ok = kept(before, cross(b0 - there.xyz, c0 - there.xyz)) && kept(before, cross(b0 - there.xyz, c1 - there.xyz))
          && kept(before, cross(b1 - there.xyz, c0 - there.xyz)) && kept(before, cross(b1 - there.xyz, c1 - there.xyz));
    }
    imageStore(u_after, item_texel(v), ok ? there : here);
}
