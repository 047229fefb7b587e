#version 410
// The opaque scene drawn once into its own target (gfx/opaque_pass.py: background, box, slices, surfaces,
// where the rays need their depth) copied into the framebuffer being drawn where a blit cannot: its colour
// and its depth, so what is drawn later (the rays, translucent surfaces) is tested and ended by it as if it
// had been drawn there (the depth test set to always: every sample written).
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
    frag_color = FETCH(u_colour);
    gl_FragDepth = depth;
}
