// Shared by the marching-cubes passes: grid and brick layout, volume and word access.
//
// The volume is an RGBA image of size (ceil(n2 / 4), n1, n0): texel (q, j, i) holds
// volume[i, j, 4q .. 4q + 3].  Signs are packed 32 per uint along axis 2: word w of row
// (i, j) holds the inside bits of samples k = 32w .. 32w+31 (bit k - 32w).  Per-word data
// (signs, counts, offsets) lives in 2-D images 2^u_word_shift texels wide, word id by word id.
//
// Why images: on llvmpipe an imageLoad costs ~0.6-0.9 ns, a texelFetch ~1.7 and an SSBO
// load ~3.6 (each SSBO lane is loaded and bounds-checked on its own); stores cost about
// the same either way (benchmarks/bench_loads.py).  SSBOs remain for the output mesh, which
// the renderer draws, and for the per-brick lists.
//
// Every layout number (WORD_BITS, BRICK_I, BRICK_J, BRICK_WORDS, SAMPLES_PER_TEXEL, EDGE_MARGIN,
// GROUP_SIZE, ...) is a #define injected from app/core/layout.py, the one place it is written.
//
// Words are grouped into bricks of BRICK_I x BRICK_J rows x 1 word.  A brick is one work group
// of the per-word passes, one invocation per word;
// brick id = (bi * bricks_j + bj) * u_words + w.  Each brick has the value range
// of every sample its words' edges and cells touch, so a level outside it means
// the brick has no surface, whatever the level was before.

uniform ivec3 u_dims;      // n0, n1, n2: samples per axis
uniform int u_words;       // words per row: ceil(n2 / WORD_BITS)
uniform ivec2 u_bricks;    // bricks along axes 0 and 1 (a brick is one word deep along axis 2)
uniform uint u_brick_count;
uniform float u_level;     // level * u_sign
uniform float u_sign;      // +1: object above the level ("descent"); -1: below ("ascent")
uniform vec3 u_spacing;
uniform uint u_word_shift;  // log2 of the per-word images' width
// Multiply-and-shift constants dividing by u_words, u_dims.y and u_bricks.y (see divide()).
uniform uvec3 u_div_words;
uniform uvec3 u_div_rows;
uniform uvec3 u_div_bricks_j;
// VOLUME_FORMAT/VOLUME_IMAGE: rgba32f image3D, or for 8- and 16-bit scans their integer formats
// (core/layout.py VOLUME_TEXEL_FORMATS), read as exact floats.
layout(VOLUME_FORMAT, binding = UNIT_VOLUME) readonly uniform VOLUME_IMAGE u_volume;

const uint WORDS_PER_BRICK = uint(BRICK_WORDS);  // BRICK_I * BRICK_J, injected as a literal for local_size_x
const int QUADS_PER_WORD = WORD_BITS / SAMPLES_PER_TEXEL;  // volume texels (4 samples each) per sign word

uint linear_group() {  // dispatches fold into 2-D past 65535 groups
    return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
}

// n / d for the divisor d whose constants `magic` core/layout.py divisor_magic() made: exact for every
// 32-bit n (Granlund and Montgomery 1994, fig. 4.1).  llvmpipe divides integers lane by lane; these
// divisions, one set per vertex, once took a fifth of the whole extraction.
uint divide(uint n, uvec3 magic) {
    uint high, low;
    umulExtended(n, magic.x, high, low);
    return (high + ((n - high) >> magic.y)) >> magic.z;
}

uint word_id_of(int i, int j, int w) {
    return (uint(i) * uint(u_dims.y) + uint(j)) * uint(u_words) + uint(w);
}

// The inverse of word_id_of: (i, j, w) of word `id`.
ivec3 word_of_id(uint id) {
    uint row = divide(id, u_div_words);
    uint i = divide(row, u_div_rows);
    return ivec3(int(i), int(row - i * uint(u_dims.y)), int(id - row * uint(u_words)));
}

// Brick `brick`'s first word (i0, j0, w): brick id = (bi * bricks_j + bj) * u_words + w.
ivec3 brick_origin(uint brick) {
    uint column = divide(brick, u_div_words);
    uint bi = divide(column, u_div_bricks_j);
    return ivec3(int(bi) * BRICK_I, int(column - bi * uint(u_bricks.y)) * BRICK_J,
                 int(brick - column * uint(u_words)));
}

// The texel of word `id` in a per-word image.
ivec2 word_texel(uint id) { return ivec2(id & ((1u << u_word_shift) - 1u), id >> u_word_shift); }

// This invocation's word in brick `brick` (one invocation per word): (i, j, w), and whether it
// lies inside the grid.
ivec3 brick_word(uint brick, out bool exists) {
    int local = int(gl_LocalInvocationIndex);
    ivec3 word = brick_origin(brick) + ivec3(local / BRICK_J, local % BRICK_J, 0);
    exists = word.x < u_dims.x && word.y < u_dims.y;
    return word;
}

// Bits of a word whose samples exist (k < n2) and whose axis-2 edge exists (k < n2 - 1).
uint low_bits(int count) {
    return count >= WORD_BITS ? 0xFFFFFFFFu : (count <= 0 ? 0u : (1u << uint(count)) - 1u);
}
uint point_bits(int w) { return low_bits(u_dims.z - WORD_BITS * w); }
uint axis2_edge_bits(int w) { return low_bits(u_dims.z - 1 - WORD_BITS * w); }

// Component `c` of `v`, by selects: llvmpipe turns indexing by a variable (of arrays or
// vectors) into stack-memory traffic, which once cost half of the triangle pass.
uint pick(uvec4 v, uint c) { return c == 0u ? v.x : c == 1u ? v.y : c == 2u ? v.z : v.w; }
float pick(vec4 v, uint c) { return c == 0u ? v.x : c == 1u ? v.y : c == 2u ? v.z : v.w; }

// Samples 4q .. 4q+3 of row (i, j); past the grid's end, zeros.
vec4 quad_at(int i, int j, int q) { return vec4(imageLoad(u_volume, ivec3(q, j, i))); }
float sample_at(ivec3 p) {
    return pick(quad_at(p.x, p.y, p.z / SAMPLES_PER_TEXEL), uint(p.z % SAMPLES_PER_TEXEL));
}
float field_at(ivec3 p) { return u_sign * sample_at(p); }
