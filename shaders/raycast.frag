#version 410
// Direct volume rendering by ray casting: one ray per fragment of the box's back faces, marched from
// where it enters the box (or the eye, inside it) to where it leaves, at a fixed step in model units.
// MODE (a #define: one program per mode) is what the ray gathers:
//   MODE_MIP    the largest value on the ray,   MODE_MINIP  the smallest,   MODE_MEAN  their mean,
//     each through the colour map over the window [u_window.x, u_window.y];
//   MODE_ISO    the first crossing of u_level on the trilinear interpolant (the one the mesh comes from),
//     refined by bisection and shaded by the field's gradient as mesh.frag shades a surface;
//   MODE_DVR    emission-absorption, front to back: extinction u_density * ramp(value) per model unit
//     (Beer-Lambert within each step), colour from the map; stops once nearly opaque.
in vec3 v_model;

uniform sampler3D u_volume;    // the samples as C-ordered bytes: texture x is array axis 2 (sampled .zyx)
uniform sampler2D u_colormap;  // LUT x 1 RGBA
uniform vec3 u_extent;         // the box's far corner: (shape - 1) x spacing; the near one is 0
uniform vec3 u_shape;
uniform vec3 u_eye;            // the camera, model space
uniform float u_step;          // model units between samples
uniform vec2 u_value_map;      // value = texel * x + y (a normalised integer texture back to its values)
uniform vec2 u_window;         // values mapped to the colour map's ends
uniform float u_level;
uniform float u_inside;        // +1: the object is where values are above the level, -1: below
uniform float u_density;       // DVR: extinction per model unit at the top of the ramp
uniform vec3 u_front_color;
uniform mat4 u_view;
uniform mat4 u_projection;

out vec4 frag_color;

const int MAX_STEPS = 4096;

float value_at(vec3 p) {
    vec3 texel = (p / max(u_extent, vec3(1e-30))) * (u_shape - 1.0) + 0.5;
    return texture(u_volume, (texel / u_shape).zyx).r * u_value_map.x + u_value_map.y;
}

float mapped(float v) {
    return clamp((v - u_window.x) / max(u_window.y - u_window.x, 1e-30), 0.0, 1.0);
}

vec4 colour_of(float v) {
    int size = textureSize(u_colormap, 0).x;
    return texelFetch(u_colormap, ivec2(min(int(mapped(v) * float(size)), size - 1), 0), 0);
}

// Where the ray eye + t dir is inside the box [0, u_extent]: (t_in, t_out); t_in > t_out for none.
vec2 box_span(vec3 dir) {
    vec3 inverse = 1.0 / dir;
    vec3 a = (vec3(0.0) - u_eye) * inverse;
    vec3 b = (u_extent - u_eye) * inverse;
    vec3 near = min(a, b), far = max(a, b);
    return vec2(max(max(near.x, near.y), max(near.z, 0.0)), min(min(far.x, far.y), far.z));
}

void finish_depth(vec3 p) {   // the depth of the point the pixel shows, so later draws are hidden by it
    vec4 clip = u_projection * u_view * vec4(p, 1.0);
    gl_FragDepth = clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0);
}

vec3 gradient_at(vec3 p) {
    vec3 h = u_extent / max(u_shape - 1.0, vec3(1.0));
    return vec3(value_at(p + vec3(h.x, 0, 0)) - value_at(p - vec3(h.x, 0, 0)),
                value_at(p + vec3(0, h.y, 0)) - value_at(p - vec3(0, h.y, 0)),
                value_at(p + vec3(0, 0, h.z)) - value_at(p - vec3(0, 0, h.z))) / (2.0 * h);
}

void main() {
    vec3 dir = normalize(v_model - u_eye);
    vec2 span = box_span(dir);
    if (span.x >= span.y) discard;
    int steps = min(int(ceil((span.y - span.x) / u_step)), MAX_STEPS);
#if defined(MODE_MIP) || defined(MODE_MINIP) || defined(MODE_MEAN)
  #ifdef MODE_MINIP
    float gathered = 1e38;
  #elif defined(MODE_MIP)
    float gathered = -1e38;
  #else
    float gathered = 0.0;
  #endif
    for (int i = 0; i <= steps; ++i) {
        float v = value_at(u_eye + dir * min(span.x + float(i) * u_step, span.y));
  #ifdef MODE_MINIP
        gathered = min(gathered, v);
  #elif defined(MODE_MIP)
        gathered = max(gathered, v);
  #else
        gathered += v;
  #endif
    }
  #ifdef MODE_MEAN
    gathered /= float(steps + 1);
  #endif
    frag_color = vec4(colour_of(gathered).rgb, 1.0);
    finish_depth(u_eye + dir * span.x);
#elif defined(MODE_ISO)
    float t_before = span.x;
    float before = u_inside * (value_at(u_eye + dir * span.x) - u_level);
    if (before >= 0.0) discard;   // the ray starts inside the object: the box's face, not the surface
    for (int i = 1; i <= steps; ++i) {
        float t = min(span.x + float(i) * u_step, span.y);
        float now = u_inside * (value_at(u_eye + dir * t) - u_level);
        if (now >= 0.0) {   // crossed between t_before and t: bisect on the interpolant
            float low = t_before, high = t;
            for (int k = 0; k < 8; ++k) {
                float mid = 0.5 * (low + high);
                if (u_inside * (value_at(u_eye + dir * mid) - u_level) >= 0.0) high = mid; else low = mid;
            }
            vec3 p = u_eye + dir * high;
            vec3 normal = -u_inside * normalize(gradient_at(p) + vec3(1e-30));   // out of the object
            vec3 view_normal = normalize(mat3(u_view) * normal);
            vec3 to_eye = normalize(-(u_view * vec4(p, 1.0)).xyz);
            float diffuse = abs(dot(view_normal, to_eye));
            frag_color = vec4(u_front_color * (0.15 + 0.85 * diffuse), 1.0);
            finish_depth(p);
            return;
        }
        t_before = t;
    }
    discard;
#elif defined(MODE_DVR)
    vec3 colour = vec3(0.0);
    float transmitted = 1.0;
    float length_step = (span.y - span.x) / float(max(steps, 1));
    for (int i = 0; i < steps; ++i) {
        float v = value_at(u_eye + dir * (span.x + (float(i) + 0.5) * length_step));
        float alpha = 1.0 - exp(-u_density * mapped(v) * length_step);
        colour += transmitted * alpha * colour_of(v).rgb;
        transmitted *= 1.0 - alpha;
        if (transmitted < 0.004) break;
    }
    frag_color = vec4(colour, 1.0 - transmitted);   // premultiplied: blended ONE, ONE_MINUS_SRC_ALPHA
    finish_depth(u_eye + dir * span.x);
#endif
}
