#version 430
// The extractor's vertex records: vec4(position.xyz, value), vec4(normal.xyz, 0),
// positions in world units (array index times spacing; axis 0 is world x).
// Lighting is done in view space, where the headlight is simply the eye.
in vec3 in_position;
in vec3 in_normal;

uniform mat4 u_view;
uniform mat4 u_projection;
uniform vec4 u_clip_plane;   // the clip plane (slices.py): kept where dot(plane, (p, 1)) >= 0

out float gl_ClipDistance[1];   // used only while the renderer enables GL_CLIP_DISTANCE0

out vec3 v_view_position;
out vec3 v_view_normal;

void main() {
    vec4 view_position = u_view * vec4(in_position, 1.0);
    v_view_position = view_position.xyz;
    // The view matrix is a rigid motion, so its 3x3 part transforms normals.
    v_view_normal = mat3(u_view) * in_normal;
    gl_Position = u_projection * view_position;
    gl_ClipDistance[0] = dot(u_clip_plane, vec4(in_position, 1.0));
}
