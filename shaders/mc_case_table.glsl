// The case table of app/case_table.py, a uniform block (on llvmpipe a uniform load costs a
// tenth of an SSBO load): per case, MAX_TRIANGLES_PER_CELL packed triangles (cell edges
// e0 | e1 << 4 | e2 << 8), then the 256 triangle counts, four uints per uvec4 (std140).
layout(std140, binding = 0) uniform CaseTable { uvec4 case_table[CASE_TABLE_QUADS]; };

uint case_table_word(uint index) { return pick(case_table[index >> 2], index & 3u); }
uint triangle_count(uint cube_case) { return case_table_word(256u * MAX_TRIANGLES_PER_CELL + cube_case); }
uint triangle_edges(uint cube_case, uint t) { return case_table_word(cube_case * MAX_TRIANGLES_PER_CELL + t); }
