#version 410
// The volume's box (model space: index x spacing), drawn for its back faces: each fragment is a ray
// from the eye through the box (raycast.frag), whether the eye is outside the box or inside it.
in vec3 in_position;   // the unit cube
uniform vec3 u_box_low; // the box's near corner: where the samples' index 0 lies (Volume.origin; 0 but for a
                        // pyramid level's coarse view off the full level's grid)
uniform vec3 u_extent; // the box's far corner: u_box_low + (shape - 1) x spacing
uniform mat4 u_view;
uniform mat4 u_projection;
out vec3 v_model;

void main() {
    v_model = mix(u_box_low, u_extent, in_position);
    gl_Position = u_projection * u_view * vec4(v_model, 1.0);
}
