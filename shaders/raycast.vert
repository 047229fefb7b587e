#version 410
// The volume's box (model space: index x spacing), drawn for its back faces: each fragment is a ray
// from the eye through the box (raycast.frag), whether the eye is outside the box or inside it.
in vec3 in_position;   // the unit cube
uniform vec3 u_extent; // the box's far corner: (shape - 1) x spacing
uniform mat4 u_view;
uniform mat4 u_projection;
out vec3 v_model;

void main() {
    v_model = in_position * u_extent;
    gl_Position = u_projection * u_view * vec4(v_model, 1.0);
}
