#version 430
// Pass 7, over active bricks, one invocation per word: the triangles of the word's cells, as
// indices of the vertices that the cells' edges own (possibly in a neighbouring word or brick),
// and for each of the word's own vertices a job (word id << 7 | axis << 5 | bit, in the job
// image: vertex_jobs.glsl) from which mc_vertices.comp, run next with one invocation per vertex,
// computes the vertex.  Both need the same sign rows, so one pass loads them once.
layout(local_size_x = BRICK_WORDS) in;
#include "mc_common.glsl"
#include "mc_sign_words.glsl"
#include "mc_active_bricks.glsl"
#include "mc_case_table.glsl"
#include "vertex_jobs.glsl"
#include "triangle_runs.glsl"

layout(r32ui, binding = 2) readonly uniform uimage2D u_word_counts;
layout(rg32ui, binding = 3) readonly uniform uimage2D u_word_offsets;  // (first vertex, first triangle)
layout(std430, binding = 6) writeonly buffer Indices { uint indices[]; };
layout(std430, binding = 4) writeonly buffer VertexJobs { uint vertex_jobs[]; };  // JOB_BINDING

// Where each axis's vertices start in the words owning a cell row's edges, per sign row around
// the cells (component d0 | d1 << 1): in word w, and in word w + 1 (reached from cell 31, only
// along axes 0 and 1).
struct OwnerStarts { uvec4 along0; uvec4 along1; uvec4 along2; uvec4 next0; uvec4 next1; };

uvec3 axis_starts(uint owner) {
    uint counts = imageLoad(u_word_counts, word_texel(owner)).x;
    uint first = imageLoad(u_word_offsets, word_texel(owner)).x;
    uint after0 = first + vertices_along(counts, 0u);
    return uvec3(first, after0, after0 + vertices_along(counts, 1u));
}

OwnerStarts owner_starts(ivec3 word, bool need_next) {
    uvec3 s0 = axis_starts(word_id_of(word.x, word.y, word.z));
    uvec3 s1 = axis_starts(word_id_of(word.x + 1, word.y, word.z));
    uvec3 s2 = axis_starts(word_id_of(word.x, word.y + 1, word.z));
    uvec3 s3 = axis_starts(word_id_of(word.x + 1, word.y + 1, word.z));
    OwnerStarts s;
    s.along0 = uvec4(s0.x, s1.x, s2.x, s3.x);
    s.along1 = uvec4(s0.y, s1.y, s2.y, s3.y);
    s.along2 = uvec4(s0.z, s1.z, s2.z, s3.z);
    s.next0 = s.next1 = uvec4(0u);
    if (need_next) {  // only when the word's last cell is cut, so word w + 1 exists
        uvec3 n0 = axis_starts(word_id_of(word.x, word.y, word.z + 1));
        uvec3 n1 = axis_starts(word_id_of(word.x + 1, word.y, word.z + 1));
        uvec3 n2 = axis_starts(word_id_of(word.x, word.y + 1, word.z + 1));
        uvec3 n3 = axis_starts(word_id_of(word.x + 1, word.y + 1, word.z + 1));
        s.next0 = uvec4(n0.x, n1.x, n2.x, n3.x);
        s.next1 = uvec4(n0.y, n1.y, n2.y, n3.y);
    }
    return s;
}

// Index of the vertex on cell edge `edge` (see app/case_table.py) of cell k of the word.
uint vertex_index(CellRows rows, OwnerStarts starts, uint k, uint edge) {
    uint axis = edge >> 2, low = edge & 3u;
    // The owner's offset from the cell's corner 0 along the two axes other than `axis`.
    uint d0 = axis == 0u ? 0u : low & 1u;
    uint d1 = axis == 0u ? low & 1u : axis == 1u ? 0u : low >> 1;
    uint d2 = axis == 2u ? 0u : low >> 1;
    uint row = d0 | (d1 << 1);  // the owner's sign row among the four around the cells
    uint bit = k + d2;
    if (bit == uint(WORD_BITS)) return pick(axis == 0u ? starts.next0 : starts.next1, row);
    uint here = pick(rows.at_k, row);
    uint crossing = axis == 0u ? here ^ pick(rows.at_k, row | 1u)
                  : axis == 1u ? here ^ pick(rows.at_k, row | 2u)
                               : here ^ (here >> 1);  // bits below `bit` never need the next word
    uint start = pick(axis == 0u ? starts.along0 : axis == 1u ? starts.along1 : starts.along2, row);
    return start + uint(bitCount(crossing & ((1u << bit) - 1u)));
}

// Name each vertex the word owns in its slot, one iteration per vertex, axis by axis.
void write_vertex_jobs(uint id, uint next, uint count, uvec3 crossing) {
    uint end = next + count;
    uint axis = 0u, bits = crossing.x;
    for (; next < end; ++next) {
        while (bits == 0u) {
            ++axis;
            bits = axis == 1u ? crossing.y : crossing.z;
        }
        uint b = uint(findLSB(bits));
        bits &= bits - 1u;
        vertex_jobs[next - u_job_first] = vertex_job(id, axis, b);
    }
}

void main() {
    uint brick;
    if (!active_brick(brick)) return;
    bool exists;
    ivec3 word = brick_word(brick, exists);
    if (!exists) return;
    // The word this invocation takes: mc_word_offsets.comp ordered the brick's words by their work.
    uint local = taken_word(imageLoad(u_word_counts, word_texel(word_id_of(word.x, word.y, word.z))).x);
    word = brick_origin(brick) + ivec3(int(local) / BRICK_J, int(local) % BRICK_J, 0);
    uint id = word_id_of(word.x, word.y, word.z);
    uint counts = imageLoad(u_word_counts, word_texel(id)).x;
    uvec2 first = imageLoad(u_word_offsets, word_texel(id)).xy;
    bool jobs = writes_jobs(first.y) && vertex_total(counts) > 0u;  // a word with nothing leaves below
    if (!has_cells(word.x, word.y)) {  // the grid's last rows: edges but no cells
        if (jobs) write_vertex_jobs(id, first.x, vertex_total(counts), crossing_masks(word.x, word.y, word.z));
        return;
    }
    bool triangles = meets_triangle_window(first.y, triangle_total(counts));
    if (!jobs && !triangles) return;  // nothing for this run: an empty word, or another window's
    CellRows rows = cell_rows(word.x, word.y, word.z);
    if (jobs) write_vertex_jobs(id, first.x, vertex_total(counts), crossing_from_rows(rows, word.z));
    if (!triangles) return;

    uint next = first.y;
    uint end = next + triangle_total(counts);
    uint cells = mixed_cells(rows, word.z);
    OwnerStarts starts = owner_starts(word, (cells >> uint(WORD_BITS - 1)) != 0u);
    // One iteration per triangle (not nested loops over cells and their triangles): SIMD lanes
    // working on different words then stay in step for as long as each has triangles left.
    uint k = 0u, c = 0u, slot = 0u, cell_triangles = 0u;
    for (; next < end; ++next) {
        if (slot == cell_triangles) {
            k = uint(findLSB(cells));
            cells &= cells - 1u;
            c = cell_case(rows, k);
            cell_triangles = triangle_count(c);
            slot = 0u;
        }
        uint edges = triangle_edges(c, slot++);
        uint at = next - u_triangle_window.x;
        if (at >= u_triangle_window.y) continue;
        indices[3u * at + 0u] = vertex_index(rows, starts, k, edges & 15u);
        indices[3u * at + 1u] = vertex_index(rows, starts, k, (edges >> 4) & 15u);
        indices[3u * at + 2u] = vertex_index(rows, starts, k, (edges >> 8) & 15u);
    }
}
