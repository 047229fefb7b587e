// Shared by the marching-cubes passes: grid layout, sign words, volume sampling.
//
// The volume is a 3-D R32F texture of size (n2, n1, n0): texel (k, j, i) holds
// volume[i, j, k].  Signs are packed 32 per uint along axis 2: word w of row
// (i, j) holds the inside bits of samples k = 32w .. 32w+31 (bit k - 32w).
// Word id = (i * n1 + j) * u_words + w; every pass runs one invocation per word.

uniform ivec3 u_dims;      // n0, n1, n2: samples per axis
uniform int u_words;       // words per row: ceil(n2 / 32)
uniform uint u_word_count; // n0 * n1 * u_words
uniform float u_level;     // level * u_sign
uniform float u_sign;      // +1: object above the level ("descent"); -1: below ("ascent")
uniform vec3 u_spacing;
uniform sampler3D u_volume;

const float EDGE_MARGIN = 1.0 / 256.0;  // app/reference.py EDGE_MARGIN: vertices stay off grid points
const uint MAX_TRIANGLES = MAX_TRIANGLES_PER_CELL;  // injected by app/extractor.py from the case table
const uint CASE_COUNTS_OFFSET = 256u * MAX_TRIANGLES;

// Dispatches are 2-D when one dimension would pass 65535 groups.
uint invocation_index() {
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    return group * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
}

ivec3 word_origin(uint word_id) {  // (i, j, first k) of a word
    uint w = word_id % uint(u_words);
    uint row = word_id / uint(u_words);
    return ivec3(int(row / uint(u_dims.y)), int(row % uint(u_dims.y)), int(w) * 32);
}

uint word_id_of(int i, int j, int w) {
    return (uint(i) * uint(u_dims.y) + uint(j)) * uint(u_words) + uint(w);
}

// Bits of a word whose samples exist (k < n2) and whose axis-2 edge exists (k < n2 - 1).
uint low_bits(int count) {
    return count >= 32 ? 0xFFFFFFFFu : (count <= 0 ? 0u : (1u << uint(count)) - 1u);
}
uint point_bits(int w) { return low_bits(u_dims.z - 32 * w); }
uint axis2_edge_bits(int w) { return low_bits(u_dims.z - 1 - 32 * w); }

float field_at(ivec3 p) {
    return u_sign * texelFetch(u_volume, ivec3(p.z, p.y, p.x), 0).r;
}
