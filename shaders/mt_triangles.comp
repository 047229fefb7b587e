#version 430
// Tetrahedra pass 7, over active bricks, one invocation per word: the triangles of the tetrahedra
// of the word's cells, as indices of the vertices their edges' owners hold (the four sign rows
// around the cells, at k or k + 1, possibly in word w + 1), and the job of each vertex the word
// owns (its edge's start sample and kind; see mt_jobs.glsl) from which mt_vertices.comp computes it.
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_active_bricks.glsl"
#include "mt_common.glsl"
#include "mt_jobs.glsl"
#include "triangle_runs.glsl"

layout(rgba32ui, binding = UNIT_WORD_COUNTS) readonly uniform uimage2D u_word_counts;  // see mt_common.glsl
layout(rg32ui, binding = UNIT_WORD_OFFSETS) readonly uniform uimage2D u_word_offsets;   // (first vertex, first triangle)
layout(std430, binding = BLOCK_MESH_INDICES) writeonly buffer Indices { uint indices[]; };
layout(std430, binding = BLOCK_VERTEX_JOBS) writeonly buffer VertexJobs { uvec2 vertex_jobs[]; };

// Per sign row around the cells (component d0 | d1 << 1), its word's first vertex and kind starts.
struct Owners { uvec4 first; uvec4 starts_x; uvec4 starts_y; };

uvec3 owner(int i, int j, int w) {  // (first vertex, starts_x, starts_y) of word (i, j, w)
    uint id = word_id_of(i, j, w);
    return uvec3(imageLoad(u_word_offsets, word_texel(id)).x, imageLoad(u_word_counts, word_texel(id)).xy);
}

Owners owners_at(ivec3 word, int w) {
    uvec3 a = owner(word.x, word.y, w), b = owner(word.x + 1, word.y, w);
    uvec3 c = owner(word.x, word.y + 1, w), d = owner(word.x + 1, word.y + 1, w);
    return Owners(uvec4(a.x, b.x, c.x, d.x), uvec4(a.y, b.y, c.y, d.y), uvec4(a.z, b.z, c.z, d.z));
}

uint first_of_kind(Owners o, uint row, uint kind) {
    return pick(o.first, row) + kind_start(pick(o.starts_x, row), pick(o.starts_y, row), kind);
}

// The first vertices, in word w + 1, of the edges that cell 31's corners 4, 5 and 6 own there (bit 0):
// corner 4's kinds 0, 1 and 3, corner 5's kind 1, corner 6's kind 0 (the kinds with no step along axis 2).
struct Wrapped { uvec4 corner4_and_5; uint corner6; };

Wrapped wrapped_owners(ivec3 word) {
    Owners next = owners_at(word, word.z + 1);
    return Wrapped(uvec4(first_of_kind(next, 0u, 0u), first_of_kind(next, 0u, 1u), first_of_kind(next, 0u, 3u),
                         first_of_kind(next, 1u, 1u)), first_of_kind(next, 2u, 0u));
}

// Index of the vertex on the tetrahedron edge `code` (corner | kind << 3) of cell k of the word.
// Selects, not branches: llvmpipe runs both sides of a branch whenever one lane takes it.
uint vertex_index(CellRows rows, Owners here, Wrapped next, uint k, uint code) {
    uint corner = code & 7u, kind = code >> 3;
    uint row = corner & 3u, bit = k + (corner >> 2);
    uint below = (1u << (bit & uint(WORD_BITS - 1))) - 1u;  // bits below `bit`; none past the word
    uint index = first_of_kind(here, row, kind) + uint(bitCount(kind_crossing(rows, row, kind) & below));
    uint wrapped = corner == 4u ? (kind == 0u ? next.corner4_and_5.x : kind == 1u ? next.corner4_and_5.y
                                                                              : next.corner4_and_5.z)
                 : corner == 5u ? next.corner4_and_5.w : next.corner6;
    return bit == uint(WORD_BITS) ? wrapped : index;
}

// Write the job of each vertex the word owns: one iteration per vertex, kind by kind, as in
// mc_triangles.comp.  Not a loop per kind: the SIMD lanes (words) of a vector would then run
// each kind's loop as long as their busiest, the sum of seven maxima instead of one.
void write_vertex_jobs(uint next, uint count, CellRows rows, ivec3 word) {
    uint end = next + count;
    uint kind = 0u, bits = owned_crossings(rows, word, 0u);
    for (; next < end; ++next) {
        while (bits == 0u) bits = owned_crossings(rows, word, ++kind);
        uint b = uint(findLSB(bits));
        bits &= bits - 1u;
        ivec3 start = ivec3(word.xy, word.z * WORD_BITS + int(b));
        vertex_jobs[next - u_job_first] = mt_job(start, kind);
    }
}

void main() {
    uint brick;
    if (!active_brick(brick)) return;
    bool exists;
    ivec3 word = brick_word(brick, exists);
    if (!exists) return;
    // The word this invocation takes: mt_word_offsets.comp ordered the brick's words by work.
    uint local = imageLoad(u_word_counts, word_texel(word_id_of(word.x, word.y, word.z))).w;
    word = brick_origin(brick) + ivec3(int(local) / BRICK_J, int(local) % BRICK_J, 0);
    uint id = word_id_of(word.x, word.y, word.z);
    uvec4 counts = imageLoad(u_word_counts, word_texel(id));
    uvec2 first = imageLoad(u_word_offsets, word_texel(id)).xy;
    // A mesh larger than one storage block takes a run per window: words outside it leave at once.
    bool jobs = writes_jobs(first.y) && mt_vertex_total(counts) > 0u;  // a word with nothing leaves below
    bool triangles = meets_triangle_window(first.y, counts.z);
    if (!jobs && !triangles) return;
    CellRows rows = border_rows(word.x, word.y, word.z);
    if (jobs) write_vertex_jobs(first.x, mt_vertex_total(counts), rows, word);
    if (!triangles) return;

    uint cells = mixed_cells(rows, word.z);
    Owners here = owners_at(word, word.z);
    Wrapped next = Wrapped(uvec4(0u), 0u);
    if ((cells >> uint(WORD_BITS - 1)) != 0u) next = wrapped_owners(word);  // word w + 1 exists then
    // One iteration per triangle, as in mc_triangles.comp.
    uint at_triangle = first.y, end = first.y + counts.z;
    uint k = 0u, c = 0u, slot = 0u, cell_triangles = 0u;
    for (; at_triangle < end; ++at_triangle) {
        if (slot == cell_triangles) {
            k = uint(findLSB(cells));
            cells &= cells - 1u;
            c = cell_case(rows, k);
            cell_triangles = triangle_count(c);
            slot = 0u;
        }
        uint codes = triangle_codes(c, slot++);
        uint at = at_triangle - u_triangle_window.x;
        if (at >= u_triangle_window.y) continue;
        indices[3u * at + 0u] = vertex_index(rows, here, next, k, codes & 63u);
        indices[3u * at + 1u] = vertex_index(rows, here, next, k, (codes >> 6) & 63u);
        indices[3u * at + 2u] = vertex_index(rows, here, next, k, (codes >> 12) & 63u);
    }
}
