// Pass 7, over active bricks, one invocation per word, for any cell kind: the triangles of the word's
// cells, as indices of the vertices that the cells' edges' owners hold (possibly in a neighbouring
// word or brick), and for each of the word's own vertices a job (vertex_jobs.glsl) from which pass 8
// (cells_vertices.glsl), run next with one invocation per vertex, computes the vertex.  Both need the
// same sign rows, so one pass loads them once.
//
// The .comp includes the kind (mc_cells.glsl and mc_jobs.glsl, mt_cells.glsl and mt_jobs.glsl) and
// declares `struct WordEdges`, what the kind keeps of a word to name its cells' vertices, before
// this; after it, the .comp defines the four functions declared below.
#include "mc_active_bricks.glsl"
#include "triangle_runs.glsl"

#include "cells_triangle_bindings.glsl"

// The jobs of the `count` vertices that word `word` (grid id `id`, the rows' corner 0) owns, into
// vertex_jobs[next - u_job_first ...].
void write_vertex_jobs(ivec3 word, uint id, uint next, uint count, CellRows rows);
// What names the vertices of the word's cut `cells`; then, per cell k, enter_cell(k, its table entry:
// cell_entry()) before vertex_index(code) names the vertex of each of its triangles' vertex codes
// (TABLE_CODE_BITS each).
WordEdges word_edges(CellRows rows, ivec3 word, uint cells);
void enter_cell(inout WordEdges edges, uint k, uint entry);
uint vertex_index(WordEdges edges, uint code);

void main() {
    uint brick;
    ivec3 word;
    if (!active_word(brick, word)) return;
    // The word this invocation takes: pass 6 ordered the brick's words by their work.
    uint local = counts_taken(imageLoad(u_word_counts, word_texel(word_id_of(word.x, word.y, word.z))));
    word = brick_origin(brick) + ivec3(int(local) / BRICK_J, int(local) % BRICK_J, 0);
    uint id = word_id_of(word.x, word.y, word.z);
    uvec4 counts = imageLoad(u_word_counts, word_texel(id));
    uvec2 first = imageLoad(u_word_offsets, word_texel(id)).xy;
    // A mesh larger than one storage block takes a run per window: words outside it leave at once.
    bool jobs = writes_jobs(first.y) && counts_vertices(counts) > 0u;  // a word with nothing leaves below
    bool triangles = meets_triangle_window(first.y, counts_triangles(counts));  // none in the grid's last rows
    if (!jobs && !triangles) return;
    CellRows rows = border_rows(word.x, word.y, word.z);
    if (jobs) write_vertex_jobs(word, id, first.x, counts_vertices(counts), rows);
    if (!triangles) return;

    uint cells = mixed_cells(rows, word.z);
    WordEdges edges = word_edges(rows, word, cells);
    // One iteration per triangle (not nested loops over cells and their triangles): SIMD lanes
    // working on different words then stay in step for as long as each has triangles left.
    uint at_triangle = first.y, end = first.y + counts_triangles(counts);
    uint k = 0u, c = 0u, slot = 0u, cell_triangles = 0u;
    const uint code_mask = (1u << TABLE_CODE_BITS) - 1u;
    for (; at_triangle < end; ++at_triangle) {
        if (slot == cell_triangles) {
            k = uint(findLSB(cells));
            cells &= cells - 1u;
            c = cell_entry(rows, word, k);
            cell_triangles = triangle_count(c);
            slot = 0u;
            enter_cell(edges, k, c);
        }
        uint codes = triangle_codes(c, slot++);
        uint at = at_triangle - u_triangle_window.x;
        if (at >= u_triangle_window.y) continue;
        indices[3u * at + 0u] = vertex_index(edges, codes & code_mask);
        indices[3u * at + 1u] = vertex_index(edges, (codes >> TABLE_CODE_BITS) & code_mask);
        indices[3u * at + 2u] = vertex_index(edges, (codes >> (2u * TABLE_CODE_BITS)) & code_mask);
    }
}
