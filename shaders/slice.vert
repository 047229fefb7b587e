#version 410
// A slice plane: world position, and where on the slice image it is, in samples (row, column).
in vec3 in_position;
in vec2 in_voxel;

uniform mat4 u_view;
uniform mat4 u_projection;

out vec2 v_voxel;

void main() {
    v_voxel = in_voxel;
    gl_Position = u_projection * u_view * vec4(in_position, 1.0);
}
