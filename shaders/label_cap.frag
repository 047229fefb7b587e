#version 410
// The clip's cut through a label map, each label's part in its colour (gfx/label_scene.py).
// A label's surface is marching cubes of its indicator at 0.5: on a grid plane its cut is marching
// squares with every vertex at an edge's midpoint, the two inside corners of an ambiguous square
// cut off on their own.  So a pixel belongs to the label of its nearest sample c when c's label
// continues along either edge from c, or the pixel is within the corner triangle (|dx| + |dy| < 0.5)
// around c; else to the label of the three other corners when they all have it; else to none.
// The plane holds each sample's index in the table (0: background), one voxel of background
// round the volume, so a label at the border is cut to its surface there too.
in vec2 v_voxel;                 // (row, column), in samples

uniform sampler2D u_plane;       // R32F, texel (column, row): the sample's index in u_table
uniform sampler2D u_table;       // RGBA32F, TABLE_WIDTH wide: index -> colour, alpha 0 where no cut is drawn

out vec4 frag_color;

int index_at(ivec2 p) {
    ivec2 size = textureSize(u_plane, 0).yx;     // (rows, columns)
    if (any(lessThan(p, ivec2(0))) || any(greaterThanEqual(p, size))) return 0;
    return int(texelFetch(u_plane, p.yx, 0).r);
}

void main() {
    ivec2 base = ivec2(floor(v_voxel));
    vec2 f = v_voxel - vec2(base);
    ivec2 near = ivec2(f.x >= 0.5 ? 1 : 0, f.y >= 0.5 ? 1 : 0);
    ivec2 c = base + near;
    ivec2 away = ivec2(1) - 2 * near;           // from c towards the square's other corners
    vec2 off = abs(v_voxel - vec2(c));
    int l = index_at(c);
    int a = index_at(c + ivec2(away.x, 0)), b = index_at(c + ivec2(0, away.y)), d = index_at(c + away);
    int owner = 0;
    if (l != 0 && (a == l || b == l || off.x + off.y < 0.5)) {
        owner = l;
    } else if (a != 0 && a == b && b == d && off.x + off.y >= 0.5) {
        owner = a;
    }
    vec4 color = texelFetch(u_table, ivec2(owner % TABLE_WIDTH, owner / TABLE_WIDTH), 0);
    if (owner == 0 || color.a == 0.0) discard;
    frag_color = vec4(color.rgb, 1.0);
}
