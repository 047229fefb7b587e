// The case table of isoscope.core.case_table in an r32ui image 2^CASE_TABLE_SHIFT texels wide: per
// case, MAX_TRIANGLES_PER_CELL packed triangles, three vertex codes TABLE_CODE_BITS apart (the table's
// code_bits: for the cubes, cell edges e0 | e1 << 4 | e2 << 8; the tetrahedra's codes are in
// mt_cells.glsl), then the 256 triangle counts.  An image, not a uniform block: a cell's case differs
// from lane to lane, and on llvmpipe a uniform uvec4 at a varying index is four loads per lane before
// pick() takes one, where an imageLoad of one r32ui texel is one gather (noise 160^3: the tetrahedra's
// triangle pass ~8-16% faster).
layout(r32ui, binding = UNIT_CASE_TABLE) readonly uniform uimage2D u_case_table;

uint case_table_word(uint index) {
    return imageLoad(u_case_table, ivec2(index & ((1u << CASE_TABLE_SHIFT) - 1u), index >> CASE_TABLE_SHIFT)).x;
}
uint triangle_count(uint cube_case) { return case_table_word(256u * MAX_TRIANGLES_PER_CELL + cube_case); }
uint triangle_codes(uint cube_case, uint t) { return case_table_word(cube_case * MAX_TRIANGLES_PER_CELL + t); }
