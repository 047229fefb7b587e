#version 410
// The opaque scene drawn once into its own target (gfx/opaque_pass.py: surfaces and slices, where the
// rays need their depth) copied into the framebuffer being drawn: its colour and its depth, so what is
// drawn later (the rays, translucent surfaces) is tested and ended by it as if it had been drawn there.
// Where nothing was drawn (depth 1) the sample is left as it is (the background, the box's lines).
// With MULTISAMPLE every sample is copied on its own (reading gl_SampleID runs per sample).
#ifdef MULTISAMPLE
uniform sampler2DMS u_colour;
uniform sampler2DMS u_depth;
#define FETCH(t) texelFetch(t, ivec2(gl_FragCoord.xy), gl_SampleID)
#else
uniform sampler2D u_colour;
uniform sampler2D u_depth;
#define FETCH(t) texelFetch(t, ivec2(gl_FragCoord.xy), 0)
#endif

out vec4 frag_color;

void main() {
    float depth = FETCH(u_depth).r;
    if (depth >= 1.0) discard;
    frag_color = FETCH(u_colour);
    gl_FragDepth = depth;
}
