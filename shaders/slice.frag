#version 410
// A slice through the volume: its values (bilinear between samples) through a colour map with a
// window/level, and the isocurve at u_iso on top.  The curve is marching squares on this pixel's
// grid square, as the 3-D extractor cuts a cell face: vertices linear along the sign-changing
// edges (a tie moved EDGE_MARGIN off the grid point), the two inside corners of an ambiguous
// square each cut off on their own (Montani 1994).  So on a slice at a grid index the curve is
// exactly where the mesh crosses the plane.  Its width is measured in pixels via the screen
// derivatives of the slice coordinates.
in vec2 v_voxel;                 // (row, column), in samples

uniform sampler2D u_slice;       // R32F, texel (column, row)
uniform sampler2D u_colormap;    // LUT_SIZE x 1 RGBA
uniform float u_window;          // values u_level -+ u_window / 2 span the colour map
uniform float u_level;
uniform float u_iso;
uniform bool u_inside_above;     // the object is where values are >= u_iso (else <=)
uniform vec3 u_curve_color;
uniform bool u_cap;              // the clip's cut: drawn only inside the object (and on its curve)

out vec4 frag_color;

const float CURVE_HALF_WIDTH = 0.9;   // pixels
const float HALO_DARKNESS = 0.6;

float sample_at(ivec2 p) {
    return texelFetch(u_slice, p.yx, 0).r;
}

bool inside(float v) {
    return u_inside_above ? v >= u_iso : v <= u_iso;
}

// Where the level crosses the edge from corner a (value va) to corner b.
vec2 crossing(vec2 a, vec2 b, float va, float vb) {
    float t = (u_iso - va) / (vb - va);
    if (va == u_iso || vb == u_iso) t = clamp(t, EDGE_MARGIN, 1.0 - EDGE_MARGIN);
    return mix(a, b, t);
}

// Distance in pixels from p to the segment a-b (slice coordinates), with dx, dy the slice
// coordinates' change per pixel.
float pixels_to_segment(vec2 p, vec2 a, vec2 b, vec2 dx, vec2 dy) {
    vec2 ab = b - a;
    float t = clamp(dot(p - a, ab) / max(dot(ab, ab), 1e-12), 0.0, 1.0);
    vec2 off = p - (a + t * ab);
    float len = length(off);
    if (len == 0.0) return 0.0;
    vec2 n = off / len;
    float per_pixel = length(vec2(dot(dx, n), dot(dy, n)));   // slice units per pixel along n
    return len / max(per_pixel, 1e-12);
}

void main() {
    vec2 dx = dFdx(v_voxel), dy = dFdy(v_voxel);
    ivec2 size = textureSize(u_slice, 0).yx;                   // (rows, columns)
    ivec2 cell = clamp(ivec2(floor(v_voxel)), ivec2(0), max(size - 2, ivec2(0)));
    vec2 f = clamp(v_voxel - vec2(cell), 0.0, 1.0);
    // Corners: c0 (0,0), c1 (1,0), c2 (0,1), c3 (1,1) in (row, column) offsets.
    ivec2 far = min(cell + 1, size - 1);
    float v0 = sample_at(cell), v1 = sample_at(ivec2(far.x, cell.y));
    float v2 = sample_at(ivec2(cell.x, far.y)), v3 = sample_at(far);
    float value = mix(mix(v0, v1, f.x), mix(v2, v3, f.x), f.y);

    float t = clamp((value - (u_level - 0.5 * u_window)) / u_window, 0.0, 1.0);
    float lut_size = float(textureSize(u_colormap, 0).x);
    vec3 color = texture(u_colormap, vec2((t * (lut_size - 1.0) + 0.5) / lut_size, 0.5)).rgb;

    // Edges: 0 c0-c1, 1 c2-c3 (along rows), 2 c0-c2, 3 c1-c3 (along columns).
    bool i0 = inside(v0), i1 = inside(v1), i2 = inside(v2), i3 = inside(v3);
    vec2 p0 = vec2(0, 0), p1 = vec2(1, 0), p2 = vec2(0, 1), p3 = vec2(1, 1);
    vec2 e[4];
    int n = 0;
    if (i0 != i1) e[n++] = crossing(p0, p1, v0, v1);
    if (i2 != i3) e[n++] = crossing(p2, p3, v2, v3);
    if (i0 != i2) e[n++] = crossing(p0, p2, v0, v2);
    if (i1 != i3) e[n++] = crossing(p1, p3, v1, v3);
    float distance = 1e9;
    if (n == 2) {
        distance = pixels_to_segment(f, e[0], e[1], dx, dy);
    } else if (n == 4) {
        // e[0..3] are on edges 0, 1, 2, 3.  Inside corners c0 and c3: c0 is cut off by the
        // segment between edges 0 and 2, c3 by 1 and 3.  Inside c1 and c2: c1 by 0 and 3, c2 by 1 and 2.
        if (i0) {
            distance = min(pixels_to_segment(f, e[0], e[2], dx, dy), pixels_to_segment(f, e[1], e[3], dx, dy));
        } else {
            distance = min(pixels_to_segment(f, e[0], e[3], dx, dy), pixels_to_segment(f, e[1], e[2], dx, dy));
        }
    }
    float coverage = clamp(CURVE_HALF_WIDTH + 0.5 - distance, 0.0, 1.0);
    float halo = clamp(CURVE_HALF_WIDTH + 1.5 - distance, 0.0, 1.0);   // a dark rim: the curve reads on light data too
    color = mix(mix(color, vec3(0.0), HALO_DARKNESS * halo), u_curve_color, coverage);
    if (u_cap && coverage == 0.0 && !inside(value)) discard;
    frag_color = vec4(color, 1.0);
}
