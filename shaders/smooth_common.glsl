// Shared by the smoothing passes (isoscope.gpu.smooth; numpy mirror: isoscope.cpu.smooth).
//
// Positions are kept in index units (position / spacing) as vec4(x, free axes), where w holds
// bits 1, 2, 4: the axes along which the vertex may move (0 where it lies on the volume's border).
// Neighbour lists: vertex v's neighbours are neighbours[first .. last), (first, last) its ring in
// u_rings (the scanned counts ends[v], ends[v + 1]), the far ends of its outgoing half-edges, each
// with the third corner of the half-edge's triangle.
// Per-vertex and per-half-edge data live in 2-D images 2^IMAGE_SHIFT texels wide, item i at texel
// (i mod width, i / width): on llvmpipe an imageLoad costs a fraction of an SSBO load (see
// mc_common.glsl), and the gathers are most of an iteration.  UMBRELLA_WEIGHT, NEWTON_STEPS, BORDER
// and FLOOR_SQUARED are #defines from isoscope.cpu.smooth.
#include "mc_common.glsl"

uniform uint u_vertex_count;

layout(std430, binding = BLOCK_ENDS) buffer Ends { uint ends[]; };

vec3 free_axes(float bits) {
    uint b = uint(bits);
    return vec3(uvec3(b & 1u, (b >> 1) & 1u, (b >> 2) & 1u));
}

ivec2 item_texel(uint i) { return ivec2(i & ((1u << IMAGE_SHIFT) - 1u), i >> IMAGE_SHIFT); }

uint vertex_index() { return linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex; }

// The cell of x (index units, clamped into the grid's cells).
ivec3 cell_of(vec3 x) { return clamp(ivec3(floor(x)), ivec3(0), u_dims - 2); }

// The (sign-adjusted) samples at cell c's corners: [0] = (v000, v001, v010, v011), [1] = (v100, ...).
mat2x4 cell_samples(ivec3 c) {
    return mat2x4(vec4(field_at(c), field_at(c + ivec3(0, 0, 1)), field_at(c + ivec3(0, 1, 0)),
                       field_at(c + ivec3(0, 1, 1))),
                  vec4(field_at(c + ivec3(1, 0, 0)), field_at(c + ivec3(1, 0, 1)), field_at(c + ivec3(1, 1, 0)),
                       field_at(c + ivec3(1, 1, 1))));
}

// Sample d (0/1 per axis) of the cell whose samples cell_samples() gave.
float corner_sample(mat2x4 s, ivec3 d) { return pick(d.x == 0 ? s[0] : s[1], uint(2 * d.y + d.z)); }

// The trilinear interpolant at x in cell c with samples s (cell_samples(c)) and its gradient in
// index units: returns vec4(gradient, value).
vec4 trilinear_in(vec3 x, ivec3 c, mat2x4 s) {
    vec3 f = x - vec3(c);
    float v000 = s[0].x, v001 = s[0].y, v010 = s[0].z, v011 = s[0].w;
    float v100 = s[1].x, v101 = s[1].y, v110 = s[1].z, v111 = s[1].w;
    float c00 = mix(v000, v001, f.z), c01 = mix(v010, v011, f.z);
    float c10 = mix(v100, v101, f.z), c11 = mix(v110, v111, f.z);
    float d0 = mix(c00, c01, f.y), d1 = mix(c10, c11, f.y);
    float e0 = mix(v001 - v000, v011 - v010, f.y), e1 = mix(v101 - v100, v111 - v110, f.y);
    return vec4(d1 - d0, mix(c01 - c00, c11 - c10, f.x), mix(e0, e1, f.x), mix(d0, d1, f.x));
}
