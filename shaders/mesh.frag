#version 410
// Two-sided Blinn-Phong: a headlight plus a fill light from the upper left (lighting.glsl).
// Back faces get their own colour, so holes and inside-out surfaces show.
// With OIT defined, a translucent surface's fragment goes to the weighted blended
// accumulation targets instead (oit.py; McGuire & Bavoil 2013).
in vec3 v_view_position;
in vec3 v_view_normal;
in float v_map_coord;

uniform vec3 u_front_color;
uniform vec3 u_back_color;
uniform bool u_lighting;
uniform int u_color_source;     // > 0: the front colour comes from the colour map
uniform sampler2D u_colormap;   // LUT_SIZE x 1 RGB
uniform float u_opacity;

#ifdef OIT
layout(location = 0) out vec4 accum;     // rgb: sum of w * a * colour; a: product of (1 - a)
layout(location = 1) out vec4 weights;   // r: sum of w * a
#else
out vec4 frag_color;
#endif

#include "lighting.glsl"

vec3 shade() {
    vec3 front = u_front_color;
    if (u_color_source > 0) {
        int size = textureSize(u_colormap, 0).x;
        front = texelFetch(u_colormap, ivec2(min(int(v_map_coord * float(size)), size - 1), 0), 0).rgb;
    }
#ifdef OIT
    vec3 albedo = front;   // a translucent shell's inside, seen through it, in its own colour
#else
    vec3 albedo = gl_FrontFacing ? front : u_back_color;
#endif
    if (!u_lighting) return albedo;
    vec3 normal = normalize(v_view_normal);
    if (!gl_FrontFacing) normal = -normal;
    vec3 to_eye = normalize(-v_view_position);
    return lit_albedo(albedo, normal, to_eye);
}

void main() {
#ifdef OIT
    // McGuire & Bavoil's depth weight (their eq. 10): nearer fragments count for more.
    float a = u_opacity;
    float w = a * clamp(3e3 * pow(1.0 - gl_FragCoord.z, 3.0), 1e-2, 3e3);
    accum = vec4(shade() * a * w, a);
    weights = vec4(a * w, 0.0, 0.0, 0.0);
#else
    frag_color = vec4(shade(), 1.0);
#endif
}
