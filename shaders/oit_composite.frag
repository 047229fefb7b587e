#version 410
// Weighted blended OIT's resolve (oit.py): the translucent layers' weighted mean colour over
// the opaque scene, by the revealage (the product of (1 - a) of the layers at the pixel).
// Premultiplied alpha, so a transparent background stays transparent where nothing is.
// With MULTISAMPLE every sample is resolved on its own (reading gl_SampleID runs per sample).
#ifdef MULTISAMPLE
uniform sampler2DMS u_scene;
uniform sampler2DMS u_accum;
uniform sampler2DMS u_weights;
#define FETCH(t) texelFetch(t, ivec2(gl_FragCoord.xy), gl_SampleID)
#else
uniform sampler2D u_scene;
uniform sampler2D u_accum;
uniform sampler2D u_weights;
#define FETCH(t) texelFetch(t, ivec2(gl_FragCoord.xy), 0)
#endif

out vec4 frag_color;

void main() {
    vec4 scene = FETCH(u_scene);
    vec4 accum = FETCH(u_accum);
    float weight = FETCH(u_weights).r;
    float revealage = accum.a;
    vec3 mean = accum.rgb / max(weight, 1e-5);
    frag_color = vec4(mean * (1.0 - revealage), 1.0 - revealage) + scene * revealage;
}
