// The trilinear topology's key table (isoscope.core.trilinear_table.TrilinearTable.packed_for_gpu) in
// an r32ui image 2^CASE_TABLE_SHIFT texels wide, at the case table's unit (mc_case_table.glsl says why
// an image): per case its ambiguous faces, whether its key needs the samples, and the header of the key
// that is the case (<< 7); per key (81,920) a header, where its list starts | triangles << 17 | own
// vertices << 21; the lists: per key its own vertices' edge masks (12 bits), then its triangles (codes
// 4 bits apart: 0-11 the cell's edges, 12 + n its own vertex n).  Only the keys with triangles have a
// list.  A cell's table entry (cell_entry, what the passes carry) is its key's header: what the
// functions below read a key by, one load fewer each.
layout(r32ui, binding = UNIT_CASE_TABLE) readonly uniform uimage2D u_case_table;

const uint NEEDS_SAMPLES = 64u;  // case_info's bit: some decision of the case changes its triangles
const uint KEY_HEADERS = 256u;   // where the headers start
const uint FIRST_OWN_CODE = 12u; // trilinear_table.FIRST_CELL_VERTEX

uint case_table_word(uint index) {
    return imageLoad(u_case_table, ivec2(index & ((1u << CASE_TABLE_SHIFT) - 1u), index >> CASE_TABLE_SHIFT)).x;
}
uint case_info(uint cube_case) { return case_table_word(cube_case); }
uint key_header(uint key) { return case_table_word(KEY_HEADERS + key); }
uint plain_header(uint info) { return info >> 7; }  // the header of the key that is the case
uint triangle_count(uint header) { return (header >> 17) & 15u; }
uint own_count(uint header) { return header >> 21; }
uint own_mask(uint header, uint n) { return case_table_word((header & 0x1FFFFu) + n); }
uint triangle_codes(uint header, uint t) { return case_table_word((header & 0x1FFFFu) + (header >> 21) + t); }

// Bit `face` where the case's face `face` is ambiguous and joins its inside corners: the product of
// one diagonal's differences against the other's (isoscope.cpu.trilinear.face_keys), corners c0 c1 c2 c3.
uint face_bit(uint info, uint face, double c0, double c1, double c2, double c3) {
    if (((info >> face) & 1u) == 0u) return 0u;
    precise double first = c0 * c2;
    precise double second = c1 * c3;
    bool joins = c0 >= 0.0LF ? first >= second : second >= first;
    return joins ? 1u << face : 0u;
}
