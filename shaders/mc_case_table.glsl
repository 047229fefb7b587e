// The case table of app/case_table.py (binding 4): per case, MAX_TRIANGLES_PER_CELL packed
// triangles (cell edges e0 | e1 << 4 | e2 << 8), then the 256 triangle counts.
layout(std430, binding = 4) readonly buffer CaseTable { uint case_table[]; };

uint triangle_count(uint cube_case) { return case_table[256u * MAX_TRIANGLES_PER_CELL + cube_case]; }
uint triangle_edges(uint cube_case, uint t) { return case_table[cube_case * MAX_TRIANGLES_PER_CELL + t]; }
