// The meshes' light (mesh.frag), shared with the ray caster's shaded samples (raycast.frag): Blinn-Phong
// with a headlight plus a fill light from the upper left, in view space; the normal faces the eye.
const vec3 FILL_DIRECTION = normalize(vec3(-0.6, 0.7, 0.4));   // towards the light, view space

vec3 blinn_phong(vec3 normal, vec3 to_light, vec3 to_eye, vec3 albedo, float strength) {
    float diffuse = max(dot(normal, to_light), 0.0);
    vec3 half_vector = normalize(to_light + to_eye);
    float specular = diffuse > 0.0 ? pow(max(dot(normal, half_vector), 0.0), 48.0) : 0.0;
    return strength * (albedo * diffuse + vec3(0.35) * specular);
}

vec3 lit_albedo(vec3 albedo, vec3 normal, vec3 to_eye) {
    return 0.12 * albedo
         + blinn_phong(normal, to_eye, to_eye, albedo, 0.85)           // headlight
         + blinn_phong(normal, FILL_DIRECTION, to_eye, albedo, 0.35);  // fill
}
