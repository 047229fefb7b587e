#version 410
// The extractor's vertex records: vec4(position.xyz, value), vec4(normal.xyz, 0),
// positions in world units (array index times spacing; axis 0 is world x).
// Lighting is done in view space, where the headlight is simply the eye.
in vec3 in_position;
in vec3 in_normal;
in float in_value;

uniform mat4 u_view;
uniform mat4 u_projection;
// Colour by (colorby.py): 0 off, 1 the vertex's value, 2 a scalar volume sampled at the vertex.
uniform int u_color_source;
uniform sampler3D u_scalar;     // texel (k, j, i) holds scalar[i, j, k]
uniform vec3 u_spacing;
uniform vec3 u_dims;            // the scalar volume's shape
uniform vec2 u_scalar_range;    // the scalars at the two ends of the colour map
uniform vec4 u_clip_plane;      // the clip plane (slices.py): kept where dot(plane, (p, 1)) >= 0
// Where the mesh's index x spacing 0 lies in the scene: (0, 0, 0) but for a pyramid level's coarse view whose
// samples lie off the full level's grid (Volume.origin); the bricks' meshes come placed already (0 here).
uniform vec3 u_origin;
// Where the volume on show (whose grid the scalar texture shares) puts its sample 0 in the scene: colour by
// samples it at the vertex's scene position less that, so a placed mesh and a moved one read the same texel.
uniform vec3 u_scalar_origin;

out float gl_ClipDistance[1];   // used only while the renderer enables GL_CLIP_DISTANCE0

out vec3 v_view_position;
out vec3 v_view_normal;
out float v_map_coord;          // where on the colour map, 0..1

void main() {
    vec3 position = in_position + u_origin;
    vec4 view_position = u_view * vec4(position, 1.0);
    v_view_position = view_position.xyz;
    // The view matrix is a rigid motion, so its 3x3 part transforms normals.
    v_view_normal = mat3(u_view) * in_normal;
    float scalar = in_value;
    if (u_color_source == 2) {
        vec3 index = (position - u_scalar_origin) / u_spacing;
        scalar = texture(u_scalar, (index.zyx + 0.5) / u_dims.zyx).r;
    }
    float span = u_scalar_range.y - u_scalar_range.x;
    v_map_coord = span > 0.0 ? clamp((scalar - u_scalar_range.x) / span, 0.0, 1.0) : 0.0;
    gl_Position = u_projection * view_position;
    gl_ClipDistance[0] = dot(u_clip_plane, vec4(position, 1.0));
}
