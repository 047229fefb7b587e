#version 410
// Direct volume rendering by ray casting: one ray per fragment of the box's back faces, marched from
// where it enters the box (or the eye, inside it) to where it leaves, at a fixed step in model units.
// MODE (a #define: one program per mode) is what the ray gathers:
//   MODE_MIP    the largest value on the ray,   MODE_MINIP  the smallest,   MODE_MEAN  their mean,
//     each through the colour map over the window [u_window.x, u_window.y];
//   MODE_ISO    the first crossing of u_level on the trilinear interpolant (the one the mesh comes from),
//     refined by bisection and shaded by the field's gradient as mesh.frag shades a surface;
//   MODE_DVR    emission-absorption, front to back: extinction u_density * ramp(value) per model unit
//     (Beer-Lambert within each step), colour from the map lit as a surface across the field's gradient
//     (forward differences of the trilinear interpolant; left unlit where the gradient is ~0, inside a
//     uniform region, and where a sample adds too little to the pixel to show it); stops once nearly opaque.
// The light is the meshes' (lighting.glsl), two-sided, and off where theirs is (u_lighting: the panel's
// toggle): then iso's hit and the clip's cut are the surface's flat colour and DVR's samples the map's.
// Empty space is skipped a brick at a time: u_ranges holds each brick's (min, max) over its samples (the
// cells of BRICK samples a side, their shared faces included), u_macro_ranges the same of macro bricks
// (MACRO bricks a side: a ray through empty space leaves one in a step), and a brick that cannot change the result
// (MIP: no value above the largest so far; MinIP: none below; iso: all of it on the outside of the level;
// DVR: all of it below the window) is left at its far face.  The clip plane, where there is one, cuts
// the rays: iso draws the cut through the object flat, in the surface's colour.
// BRICKED (a #define: a volume over the memory budget, model/ray_bricks.py): the box is the coarse view's (as
// the box drawn), and where the brick of the full volume a point lies in is in the atlas (u_slots: its slot's first texel and
// 1; gfx/ray_atlas.py) the samples are read there, at full resolution, else from the coarse view (u_volume);
// the ray steps u_step there and u_coarse_steps times that in the coarse view (one lattice: the samples are
// those of a ray at the full resolution's step, every u_coarse_steps-th where the view is coarse), and the
// gradient is taken at the spacing of the samples read.  The skipping ranges hold what both may read.
// What is drawn opaque before the rays (slices, opaque surfaces: u_depth, their depth) ends them there: a
// ray stopped so shows iso's hit in front of it (the only mode that writes depth), DVR over it (premultiplied),
// and MIP and mean over it as opaque as their value is bright in the window (MinIP: as it is dark), so what
// stopped the ray shows through a dark projection of what lies in front of it.
in vec3 v_model;

uniform sampler3D u_volume;    // the samples as C-ordered bytes: texture x is array axis 2 (sampled .zyx)
uniform sampler3D u_ranges;    // per brick (min, max) in values, C-ordered the same way (texelFetch .zyx)
uniform sampler2D u_colormap;  // LUT x 1 RGBA
uniform vec3 u_extent;         // the box's far corner: u_box_low + (shape - 1) x spacing
uniform vec3 u_box_low;        // the box's near corner: u_texture_origin (0 where BRICKED and it is below 0)
uniform vec3 u_texture_origin; // where u_volume's index 0 lies (Volume.origin: 0 but for a pyramid level's coarse
                               // view off the full level's grid); its bricks' ranges are looked up from there
uniform vec3 u_texture_extent; // u_volume's far corner less u_texture_origin: (its shape - 1) x its spacing
uniform vec3 u_shape;          // u_volume's samples along each axis
uniform vec3 u_brick;          // a brick's size, model units: BRICK x spacing
uniform vec3 u_bricks;         // bricks along each axis
uniform sampler3D u_macro_ranges; // the same of macro bricks, MACRO x MACRO x MACRO bricks each (the last ones fewer)
uniform vec3 u_macro;          // a macro brick's size, model units: MACRO x u_brick
uniform vec3 u_macros;         // macro bricks along each axis
uniform vec3 u_eye;            // the camera, model space
uniform float u_step;          // model units between samples
uniform vec2 u_value_map;      // value = texel * x + y (a normalised integer texture back to its values)
uniform vec2 u_window;         // values mapped to the colour map's ends
uniform float u_level;
uniform float u_inside;        // +1: the object is where values are above the level, -1: below
uniform float u_density;       // DVR: extinction per model unit at the top of the ramp
uniform vec3 u_front_color;
uniform sampler2D u_transfer;  // DVR: opacity over [u_transfer_range] (TRANSFER_SIZE x 1), where u_transfer_on
uniform float u_transfer_on;
uniform vec2 u_transfer_range;
uniform float u_transfer_floor; // values at or below it are transparent under the transfer function
uniform float u_gradient_floor; // DVR: a gradient no longer than this (values per model unit) is none
uniform vec4 u_clip_plane;     // kept where dot(plane, (p, 1)) >= 0 (slices.py); (0, 0, 0, 1): no clip
#ifdef DEPTH_MULTISAMPLE
uniform sampler2DMS u_depth;   // what is drawn opaque (window depth, its first sample), where u_depth_on:
#define DEPTH_SIZE textureSize(u_depth)   // the rays end there
#else
uniform sampler2D u_depth;     // what is drawn opaque (window depth), where u_depth_on: the rays end there
#define DEPTH_SIZE textureSize(u_depth, 0)
#endif
uniform float u_depth_on;
uniform vec2 u_depth_origin;   // a fragment's texel in u_depth: (gl_FragCoord.xy - origin) * scale
uniform vec2 u_depth_scale;
uniform mat4 u_inverse;        // (u_projection u_view)^-1: a window depth back to model space
uniform bool u_lighting;       // the meshes' lighting toggle (mesh.frag): off, colours as they are
uniform mat4 u_view;
uniform mat4 u_projection;
#ifdef BRICKED
uniform sampler3D u_atlas;     // the bricks at full resolution, a slot each, as u_volume (texture x: array axis 2)
uniform sampler3D u_slots;     // per brick of the full volume: (its slot's first texel along the array's axes, 1)
uniform vec3 u_atlas_shape;    // the atlas's texels along the array's axes
uniform vec2 u_atlas_value_map; // as u_value_map, for the atlas's texels
uniform vec3 u_fine_spacing;   // the full volume's spacing
uniform float u_cells;         // cells a side of a brick
uniform vec3 u_grid;           // bricks along each axis
uniform float u_coarse_steps;  // steps of the ray's lattice per step in the coarse view
uniform sampler3D u_atlas_ranges; // per slot, the (min, max) of its brick's bricks of u_range_cells cells a side
uniform float u_range_cells;   // RANGE_BRICK: full samples a side of those
uniform float u_slot_ranges;   // their number along each axis of a slot
#endif

out vec4 frag_color;

#include "lighting.glsl"

const int MAX_STEPS = 8192;

#ifdef BRICKED
// The brick of the full volume p lies in (`brick`, its index; `local`, p in its samples): (its slot's first
// texel, 1) where it is in the atlas, else 0s.
vec4 slot_at(vec3 p, out vec3 brick, out vec3 local) {
    vec3 q = p / u_fine_spacing;
    brick = clamp(floor(q / u_cells), vec3(0.0), u_grid - 1.0);
    local = clamp(q - brick * u_cells, vec3(0.0), vec3(u_cells));
    return texelFetch(u_slots, ivec3(brick).zyx, 0);
}

bool full_at(vec3 p) {
    vec3 brick, local;
    return slot_at(p, brick, local).w > 0.5;
}
#endif

// The value at p from the coarse view (u_volume).
float coarse_value(vec3 p) {
    vec3 texel = ((p - u_texture_origin) / max(u_texture_extent, vec3(1e-30))) * (u_shape - 1.0) + 0.5;
    return texture(u_volume, (texel / u_shape).zyx).r * u_value_map.x + u_value_map.y;
}

#ifdef BRICKED
// The value at p, its brick's `slot` and `local` position given (slot_at), and the ray's step from there:
// u_coarse_steps of u_step where the brick is not in the atlas.
float slot_value(vec3 p, vec4 slot, vec3 local, out float step) {
    if (slot.w > 0.5) {
        step = u_step;
        vec3 texel = slot.xyz + local + 0.5;
        return texture(u_atlas, (texel / u_atlas_shape).zyx).r * u_atlas_value_map.x + u_atlas_value_map.y;
    }
    step = u_step * u_coarse_steps;
    return coarse_value(p);
}
#endif

float value_at(vec3 p) {
#ifdef BRICKED
    vec3 brick, local;
    vec4 slot = slot_at(p, brick, local);
    float step;
    return slot_value(p, slot, local, step);
#else
    return coarse_value(p);
#endif
}

vec3 spacing_at(vec3 p) {   // the spacing of the samples value_at reads at p
#ifdef BRICKED
    if (full_at(p)) return u_fine_spacing;
#endif
    return u_texture_extent / max(u_shape - 1.0, vec3(1.0));
}

float mapped(float v) {
    return clamp((v - u_window.x) / max(u_window.y - u_window.x, 1e-30), 0.0, 1.0);
}

float opacity_of(float v) {   // DVR: the transfer function, else the window's linear ramp
    if (u_transfer_on > 0.5) {
        float x = clamp((v - u_transfer_range.x) / max(u_transfer_range.y - u_transfer_range.x, 1e-30), 0.0, 1.0);
        int size = textureSize(u_transfer, 0).x;
        return texture(u_transfer, vec2((x * float(size - 1) + 0.5) / float(size), 0.5)).r;
    }
    return mapped(v);
}

vec4 colour_of(float v) {
    int size = textureSize(u_colormap, 0).x;
    return texelFetch(u_colormap, ivec2(min(int(mapped(v) * float(size)), size - 1), 0), 0);
}

// Where the ray eye + t dir is inside the box [u_box_low, u_extent]: (t_in, t_out); t_in > t_out for none.
vec2 box_span(vec3 dir) {
    vec3 inverse = 1.0 / dir;
    vec3 a = (u_box_low - u_eye) * inverse;
    vec3 b = (u_extent - u_eye) * inverse;
    vec3 near = min(a, b), far = max(a, b);
    return vec2(max(max(near.x, near.y), max(near.z, 0.0)), min(min(far.x, far.y), far.z));
}

// The span cut by the clip plane's kept half-space.
vec2 clipped(vec2 span, vec3 dir) {
    float at_eye = dot(u_clip_plane.xyz, u_eye) + u_clip_plane.w;
    float along = dot(u_clip_plane.xyz, dir);
    if (abs(along) < 1e-12) return at_eye >= 0.0 ? span : vec2(1.0, 0.0);
    float t = -at_eye / along;
    return along > 0.0 ? vec2(max(span.x, t), span.y) : vec2(span.x, min(span.y, t));
}

// How far along the ray (t) what is drawn opaque is, or 1e38 where nothing is.
float scene_end(vec3 dir) {
    if (u_depth_on < 0.5) return 1e38;
    ivec2 texel = clamp(ivec2((gl_FragCoord.xy - u_depth_origin) * u_depth_scale), ivec2(0), DEPTH_SIZE - 1);
    float depth = texelFetch(u_depth, texel, 0).r;   // level 0, or sample 0
    if (depth >= 1.0) return 1e38;
    vec4 clip = u_projection * u_view * vec4(v_model, 1.0);
    vec4 p = u_inverse * vec4(clip.xy / clip.w, 2.0 * depth - 1.0, 1.0);
    return dot(p.xyz / p.w - u_eye, dir);
}

// The brick (of `size` model units, `count` along each axis) the point p lies in, and where the ray leaves it (t).
ivec3 brick_of(vec3 p, vec3 size, vec3 count) {
    return ivec3(clamp(floor(p / size), vec3(0.0), count - 1.0));
}

float box_exit(vec3 low, vec3 high, vec3 dir) {   // where the ray leaves the box [low, high] (t)
    vec3 inverse = 1.0 / dir;
    vec3 a = (low - u_eye) * inverse, b = (high - u_eye) * inverse;
    vec3 far = max(a, b);
    return min(min(far.x, far.y), far.z);
}

bool skipped(vec2 range, float gathered) {
#if defined(MODE_MIP)
    return range.y <= gathered;
#elif defined(MODE_MINIP)
    return range.x >= gathered;
#elif defined(MODE_ISO)
    return u_inside > 0.0 ? range.y < u_level : range.x > u_level;
#elif defined(MODE_DVR)
    // transparent there: nothing absorbed, nothing emitted
    return range.y <= (u_transfer_on > 0.5 ? u_transfer_floor : u_window.x);
#else
    return false;
#endif
}

void finish_depth(vec3 p) {   // iso: the depth of the hit, so later draws (translucent surfaces) are hidden by it
    vec4 clip = u_projection * u_view * vec4(p, 1.0);
    gl_FragDepth = clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0);
}

vec3 gradient_at(vec3 p) {
    vec3 h = spacing_at(p);
    return vec3(value_at(p + vec3(h.x, 0, 0)) - value_at(p - vec3(h.x, 0, 0)),
                value_at(p + vec3(0, h.y, 0)) - value_at(p - vec3(0, h.y, 0)),
                value_at(p + vec3(0, 0, h.z)) - value_at(p - vec3(0, 0, h.z))) / (2.0 * h);
}

vec3 lit(vec3 albedo, vec3 normal, vec3 p) {   // two-sided: the normal turned to face the eye
    if (!u_lighting) return albedo;
    vec3 view_normal = normalize(mat3(u_view) * normal);
    vec3 to_eye = normalize(-(u_view * vec4(p, 1.0)).xyz);
    return lit_albedo(albedo, dot(view_normal, to_eye) < 0.0 ? -view_normal : view_normal, to_eye);
}

vec3 shaded(vec3 albedo, vec3 p, float v) {   // DVR: a sample lit across the gradient, where there is one
    if (!u_lighting) return albedo;   // unlit: no gradient to read
    // Forward differences from the sample's own value v: three reads more, not six (a voxel's light is no
    // sharper than its gradient: half a voxel's shift is not seen, the frame time is).
    vec3 h = spacing_at(p);
    vec3 gradient = vec3(value_at(p + vec3(h.x, 0, 0)) - v, value_at(p + vec3(0, h.y, 0)) - v,
                         value_at(p + vec3(0, 0, h.z)) - v) / h;
    return length(gradient) <= u_gradient_floor ? albedo : lit(albedo, gradient / length(gradient), p);
}

void main() {
    vec3 dir = normalize(v_model - u_eye);
    vec2 box = box_span(dir);
    vec2 span = clipped(box, dir);
    float end = scene_end(dir);
    bool stopped = end < span.y;   // by something drawn opaque
    span.y = min(span.y, end);
    if (span.x >= span.y) discard;
    float t = span.x;
#if defined(MODE_MINIP)
    float gathered = 1e38;
#elif defined(MODE_MIP)
    float gathered = -1e38;
#else
    float gathered = 0.0;
#endif
#if defined(MODE_MEAN)
    float count = 0.0;
#endif
#if defined(MODE_ISO)
    float t_before = t;
    float before = u_inside * (value_at(u_eye + dir * t) - u_level);
    if (before >= 0.0) {   // the ray starts inside the object: at the box's face, or the clip's cut
        if (span.x > box.x + 1e-6 * length(u_extent)) {
            vec3 p = u_eye + dir * span.x;
            frag_color = vec4(lit(u_front_color, u_clip_plane.xyz, p), 1.0);
            finish_depth(p);
            return;
        }
        discard;
    }
#endif
#if defined(MODE_DVR)
    vec3 colour = vec3(0.0);
    float transmitted = 1.0;
#endif
    for (int i = 0; i < MAX_STEPS && t <= span.y; ++i) {
        vec3 p = u_eye + dir * t;
#ifdef BRICKED   // p's brick, looked up once for the skipping and the sample
        vec3 whole, local;
        vec4 slot = slot_at(p, whole, local);
#endif
#if !defined(MODE_MEAN)   // a mean takes every sample: nothing to skip
        // The macro brick first (one fetch leaves MACRO bricks a side behind), then the brick.  The coarse view's
        // bricks are where its samples are (from u_texture_origin), wherever p is: a brick read in full widened
        // every one of them its cells reach into (model/ray_bricks.py), so a box skipped holds no sample, coarse
        // or full, that a ray inside it reads.
        vec3 moved = u_texture_origin, at = p - moved;
        ivec3 brick = brick_of(at, u_macro, u_macros);
        vec3 low = vec3(brick) * u_macro + moved, high = low + u_macro;
        bool skip = skipped(texelFetch(u_macro_ranges, brick.zyx, 0).rg, gathered);
        if (!skip) {
#ifdef BRICKED
            // In a brick read in full: its own ranges, RANGE_BRICK full samples a side (within the brick).
            if (slot.w > 0.5) {
                vec3 r = min(floor(local / u_range_cells), vec3(u_slot_ranges - 1.0));
                ivec3 entry = ivec3(slot.xyz / (u_cells + 1.0) * u_slot_ranges + r + 0.5);
                skip = skipped(texelFetch(u_atlas_ranges, entry.zyx, 0).rg, gathered);
                low = (whole * u_cells + r * u_range_cells) * u_fine_spacing;
                high = min(low + u_range_cells * u_fine_spacing, min((whole + 1.0) * u_cells * u_fine_spacing, u_extent));
            } else
#endif
            {
                brick = brick_of(at, u_brick, u_bricks);
                low = vec3(brick) * u_brick + moved;
                high = low + u_brick;
                skip = skipped(texelFetch(u_ranges, brick.zyx, 0).rg, gathered);
            }
        }
        if (skip) {
            float leave = box_exit(low, high, dir);
            // On to the first sample of the ray's own lattice (span.x + k u_step) past the brick's far face:
            // the samples taken are those a march without skipping takes, less the skipped ones, so the
            // picture is the same.  At least one step on: a position on the face may round into this brick.
            t = max(span.x + (floor((leave - span.x) / u_step) + 1.0) * u_step, t + u_step);
#if defined(MODE_ISO)
            t_before = t - u_step;   // in the skipped brick (or on its face): outside the level
#endif
            continue;
        }
#endif
#ifdef BRICKED
        float step;
        float v = slot_value(p, slot, local, step);
        if (step > u_step) {   // a coarse step ends at the first sample of the lattice past its brick's far face:
            // a brick read in full beyond it is read from its first full samples on, none stepped over
            vec3 brick_low = whole * u_cells * u_fine_spacing;
            float leave = box_exit(brick_low, brick_low + u_cells * u_fine_spacing, dir);
            step = clamp(span.x + (floor((leave - span.x) / u_step) + 1.0) * u_step - t, u_step, step);
        }
#else
        float step = u_step;
        float v = coarse_value(p);
#endif
#if defined(MODE_MINIP)
        gathered = min(gathered, v);
#elif defined(MODE_MIP)
        gathered = max(gathered, v);
#elif defined(MODE_MEAN)
        gathered += v * step;   // weighed by the length it stands for (a coarse view's step is longer)
        count += step;
#elif defined(MODE_ISO)
        float now = u_inside * (v - u_level);
        if (now >= 0.0 && i > 0) {   // crossed between t_before and t: bisect on the interpolant
            float low = t_before, high = t;
            for (int k = 0; k < 8; ++k) {
                float mid = 0.5 * (low + high);
                if (u_inside * (value_at(u_eye + dir * mid) - u_level) >= 0.0) high = mid; else low = mid;
            }
            vec3 hit = u_eye + dir * high;
            frag_color = vec4(lit(u_front_color, normalize(gradient_at(hit) + vec3(1e-30)), hit), 1.0);
            finish_depth(hit);
            return;
        }
        t_before = t;
#elif defined(MODE_DVR)
        float length_step = min(step, span.y - t + 1e-6);
        float alpha = 1.0 - exp(-u_density * opacity_of(v) * length_step);
        // A sample that adds under a 2048th of the pixel is left unlit: its light could not be told apart.
        float weight = transmitted * alpha;
        if (weight > 1.0 / 2048.0) colour += weight * shaded(colour_of(v).rgb, p, v);
        else if (alpha > 0.0) colour += weight * colour_of(v).rgb;
        transmitted *= 1.0 - alpha;
        if (transmitted < 0.004) break;
#endif
        t += step;
    }
#if defined(MODE_MIP) || defined(MODE_MINIP)
    // The ray's end too (the box's far face, the clip's cut, what is drawn opaque): the lattice stops up to a
    // step short of it, and where a cut crosses a bright (dark) region its extreme is right there.
    float at_end = value_at(u_eye + dir * span.y);
  #if defined(MODE_MIP)
    gathered = max(gathered, at_end);
  #else
    gathered = min(gathered, at_end);
  #endif
#endif
#if defined(MODE_ISO)
    discard;
#elif defined(MODE_DVR)
    frag_color = vec4(colour, 1.0 - transmitted);   // premultiplied: blended ONE, ONE_MINUS_SRC_ALPHA
#else
  #if defined(MODE_MEAN)
    gathered /= max(count, 1.0);
  #endif
    if (gathered < -1e37 || gathered > 1e37) discard;   // every brick skipped: nothing on the ray
  #if defined(MODE_MINIP)
    float alpha = stopped ? 1.0 - mapped(gathered) : 1.0;
  #else
    float alpha = stopped ? mapped(gathered) : 1.0;
  #endif
    frag_color = vec4(colour_of(gathered).rgb * alpha, alpha);   // premultiplied, as DVR's
#endif
}
