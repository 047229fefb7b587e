#version 410
// The volume's bounding box: 12 edges drawn as GL_LINES, corners in world units.
in vec3 in_position;

uniform mat4 u_view;
uniform mat4 u_projection;

void main() {
    gl_Position = u_projection * u_view * vec4(in_position, 1.0);
}
