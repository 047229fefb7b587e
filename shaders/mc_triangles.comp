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

layout(r32ui, binding = UNIT_WORD_COUNTS) readonly uniform uimage2D u_word_counts;
layout(rg32ui, binding = UNIT_WORD_OFFSETS) readonly uniform uimage2D u_word_offsets;  // (first vertex, first triangle)
layout(std430, binding = BLOCK_MESH_INDICES) writeonly buffer Indices { uint indices[]; };
layout(std430, binding = BLOCK_VERTEX_JOBS) writeonly buffer VertexJobs { uint vertex_jobs[]; };

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

// The word's crossing masks per owner row (isoscope.core.case_table: edge = axis * 4 + low; low's bits are
// the owner's offsets along the other two axes, the lower axis first): along axis 0 rows 0 and 2,
// along axis 1 rows 0 and 1 (edges 0, 1 and 4, 5 start at the cell's k; 2, 3 and 6, 7 at k + 1),
// along axis 2 the four rows (edges 8-11).
struct EdgeLines { uvec4 crossing01; uvec4 crossing2; uvec4 start01; };

EdgeLines edge_lines(CellRows rows, OwnerStarts starts) {
    uvec4 r = rows.at_k;
    EdgeLines e;
    e.crossing01 = uvec4(r.x ^ r.y, r.z ^ r.w, r.x ^ r.z, r.y ^ r.w);
    e.crossing2 = r ^ (r >> 1);  // bits below a cell's k never need the next word
    e.start01 = uvec4(starts.along0.xz, starts.along1.xy);
    return e;
}

// Indices of the vertices on the 12 edges of cell k (edge e in component e & 3 of vector e >> 2):
// each is its owner's first vertex along the axis plus the crossings before it in the owner's row.
// Edges at k + 1 of the word's last cell belong to the next word.
struct CellVertices { uvec4 e0; uvec4 e1; uvec4 e2; };

CellVertices cell_vertices(EdgeLines lines, OwnerStarts starts, uint k) {
    uint below = (1u << k) - 1u;
    uvec4 at_k = lines.start01 + uvec4(bitCount(lines.crossing01 & below));  // edges 0, 1, 4, 5
    uvec4 at_k1 = at_k + ((lines.crossing01 >> k) & 1u);  // edges 2, 3, 6, 7
    if (k == uint(WORD_BITS - 1)) at_k1 = uvec4(starts.next0.xz, starts.next1.xy);
    CellVertices v;
    v.e0 = uvec4(at_k.xy, at_k1.xy);
    v.e1 = uvec4(at_k.zw, at_k1.zw);
    v.e2 = starts.along2 + uvec4(bitCount(lines.crossing2 & uvec4(below)));
    return v;
}

uint edge_vertex_index(CellVertices v, uint edge) {
    uvec4 four = edge < 4u ? v.e0 : edge < 8u ? v.e1 : v.e2;
    return pick(four, edge & 3u);
}

// Name each vertex the word owns in its slot, one iteration per vertex, axis by axis.
void write_vertex_jobs(uint base, uint next, uint count, uvec3 crossing) {
    uint end = next + count;
    uvec3 left = crossing;
    for (; next < end; ++next) {  // the lowest bit of the first axis with bits left, by selects
        uint axis = left.x != 0u ? 0u : left.y != 0u ? 1u : 2u;
        uint bits = axis == 0u ? left.x : axis == 1u ? left.y : left.z;
        uvec3 lowest = uvec3(equal(uvec3(axis), uvec3(0u, 1u, 2u))) * (bits & (0u - bits));
        left &= ~lowest;
        vertex_jobs[next - u_job_first] = base | vertex_job_bits(axis, uint(findLSB(bits)));
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
        if (jobs) write_vertex_jobs(job_base(word, id), first.x, vertex_total(counts), crossing_masks(word.x, word.y, word.z));
        return;
    }
    bool triangles = meets_triangle_window(first.y, triangle_total(counts));
    if (!jobs && !triangles) return;  // nothing for this run: an empty word, or another window's
    CellRows rows = cell_rows(word.x, word.y, word.z);
    if (jobs) write_vertex_jobs(job_base(word, id), first.x, vertex_total(counts), crossing_from_rows(rows, word.z));
    if (!triangles) return;

    uint next = first.y;
    uint end = next + triangle_total(counts);
    uint cells = mixed_cells(rows, word.z);
    OwnerStarts starts = owner_starts(word, (cells >> uint(WORD_BITS - 1)) != 0u);
    // One iteration per triangle (not nested loops over cells and their triangles): SIMD lanes
    // working on different words then stay in step for as long as each has triangles left.
    EdgeLines lines = edge_lines(rows, starts);
    uint k = 0u, c = 0u, slot = 0u, cell_triangles = 0u;
    CellVertices v;
    for (; next < end; ++next) {
        if (slot == cell_triangles) {
            k = uint(findLSB(cells));
            cells &= cells - 1u;
            c = cell_case(rows, k);
            cell_triangles = triangle_count(c);
            slot = 0u;
            v = cell_vertices(lines, starts, k);
        }
        uint edges = triangle_edges(c, slot++);
        uint at = next - u_triangle_window.x;
        if (at >= u_triangle_window.y) continue;
        indices[3u * at + 0u] = edge_vertex_index(v, edges & 15u);
        indices[3u * at + 1u] = edge_vertex_index(v, (edges >> 4) & 15u);
        indices[3u * at + 2u] = edge_vertex_index(v, (edges >> 8) & 15u);
    }
}
