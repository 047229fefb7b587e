#version 430
// Two-sided Blinn-Phong: a headlight plus a fill light from the upper left.
// Back faces get their own colour, so holes and inside-out surfaces show.
in vec3 v_view_position;
in vec3 v_view_normal;

uniform vec3 u_front_color;
uniform vec3 u_back_color;
uniform bool u_lighting;

out vec4 frag_color;

const vec3 FILL_DIRECTION = normalize(vec3(-0.6, 0.7, 0.4));   // towards the light, view space

vec3 blinn_phong(vec3 normal, vec3 to_light, vec3 to_eye, vec3 albedo, float strength) {
    float diffuse = max(dot(normal, to_light), 0.0);
    vec3 half_vector = normalize(to_light + to_eye);
    float specular = diffuse > 0.0 ? pow(max(dot(normal, half_vector), 0.0), 48.0) : 0.0;
    return strength * (albedo * diffuse + vec3(0.35) * specular);
}

void main() {
    vec3 albedo = gl_FrontFacing ? u_front_color : u_back_color;
    if (!u_lighting) {
        frag_color = vec4(albedo, 1.0);
        return;
    }
    vec3 normal = normalize(v_view_normal);
    if (!gl_FrontFacing) normal = -normal;
    vec3 to_eye = normalize(-v_view_position);
    vec3 color = 0.12 * albedo
               + blinn_phong(normal, to_eye, to_eye, albedo, 0.85)           // headlight
               + blinn_phong(normal, FILL_DIRECTION, to_eye, albedo, 0.35);  // fill
    frag_color = vec4(color, 1.0);
}
