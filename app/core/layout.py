"""Every number the Python side and the shaders must agree on, in one place.

The shaders receive these as `#define`s (`shader_defines()`, added after
`#version` by `isoscope.resources.shader_source`), so a GLSL file never spells
one of them as a literal; the numpy reference and the extractor import them
from here.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError

# --- the marching-cubes grid layout ------------------------------------------------------------
WORD_BITS = 32
"""Inside bits packed per uint along axis 2: word w of a row holds samples 32w .. 32w + 31."""

BRICK_I = 8
BRICK_J = 8
"""Rows of words per brick along axes 0 and 1; a brick is one word deep along axis 2."""

BRICK_WORDS = BRICK_I * BRICK_J
"""Words per brick: one work group of the per-word passes, one invocation per word."""

SAMPLES_PER_TEXEL = 4
"""The volume image holds 4 consecutive axis-2 samples per RGBA texel."""

EDGE_MARGIN = np.float32(1.0 / 256.0)
"""Smallest edge parameter of a vertex: vertices stay this far (in edge lengths) off grid points."""

VOLUME_TEXEL_FORMATS = {
    # sample dtype: (moderngl texture dtype, GLSL image format, GLSL image type)
    "uint8": ("u1", "rgba8ui", "uimage3D"),
    "int8": ("i1", "rgba8i", "iimage3D"),
    "uint16": ("u2", "rgba16ui", "uimage3D"),
    "int16": ("i2", "rgba16i", "iimage3D"),
    "float32": ("f4", "rgba32f", "image3D"),
}
"""How each sample type is kept on the GPU.  Scans come as 8- and 16-bit integers, which go up
as they are (a quarter or half of float32's upload and memory) and read back exactly as floats;
every other type is converted to float32 on upload."""


IN_PLACE_DTYPES = ("uint8", "int8", "uint16", "int16", "float32", "float64")
"""Sample types the compiled CPU kernels read where they lie, in any memory order and byte order
(`isoscope.cpu.samples`): what the loaders give (8- and 16-bit scans, float32 and float64 fields).  Other
numbers are read from a float32 copy."""


def volume_texel_format(dtype) -> tuple[str, str, str]:
    """(moderngl dtype, GLSL format, GLSL image type) of the volume image for samples of `dtype`."""
    return VOLUME_TEXEL_FORMATS.get(str(np.dtype(dtype).newbyteorder("=")), VOLUME_TEXEL_FORMATS["float32"])


MAX_WORD_IMAGE_SHIFT = 12
"""Per-word images are at most 2^12 = 4096 texels wide."""

MAX_WORDS = 1 << 25
"""A vertex job of a grid too large for job_coordinate_bits packs its word id into the top 25 bits of a
uint (word << 7 | axis << 5 | bit)."""


def sign_words(shape) -> int:
    """The extractor's sign words for a grid: one bit per sample, WORD_BITS samples per word along
    axis 2, rows padded to whole words. Python integers: a header's dimensions cannot wrap."""
    n0, n1, n2 = (int(n) for n in shape)
    return n0 * n1 * -(-n2 // WORD_BITS)


def fits_one_extraction(shape) -> bool:
    """Whether one extractor takes a grid of `shape`: at most MAX_WORDS sign words (about 2^30 samples)."""
    return sign_words(shape) <= MAX_WORDS

JOB_BITS = 32
"""Bits of a marching-cubes vertex job (mc_jobs.glsl)."""


def job_coordinate_bits(shape) -> tuple[int, int] | None:
    """The bits of j and of k when a vertex job can hold its edge's start sample (i, j, k) and axis
    (2 bits) in JOB_BITS, for a grid of `shape`; None when it cannot (the job then holds the
    owning word's id, which the vertex pass decodes with two divisions instead of shifts)."""
    bits = [max(1, (int(n) - 1).bit_length()) for n in shape]
    return (bits[1], bits[2]) if sum(bits) + 2 <= JOB_BITS else None

# --- work-group sizes ------------------------------------------------------------------------------
GROUP_SIZE = 64
"""Invocations per work group of the one-invocation-per-item passes (per word, brick or vertex)."""

SCAN_GROUP = 256
SCAN_ITEMS_PER_INVOCATION = 32
SCAN_BLOCK = SCAN_GROUP * SCAN_ITEMS_PER_INVOCATION
"""Elements one work group of the exclusive scan sums (shaders/scan_*.comp).  32 per invocation, not 4:
llvmpipe's barriers cost more than the loads between them (a scan of the 3.7 M per-vertex counts
when smoothing noise 256^3 took ~200 ms with 4, ~60 with 32)."""

MAX_GROUPS_PER_DIMENSION = 65535
"""GL's guaranteed work groups per dispatch dimension; longer dispatches fold into 2-D."""


# --- the mesh the extractor writes and the renderer draws ------------------------------------------
VERTEX_FIELDS = (("position", 3), ("value", 1), ("normal", 3), ("", 1))
"""One vertex record, std430: vec4(position.xyz, value), vec4(normal.xyz, 0); floats per field."""

VERTEX_FLOATS = sum(n for _, n in VERTEX_FIELDS)
VERTEX_BYTES = 4 * VERTEX_FLOATS


def vertex_format(*names: str) -> str:
    """A moderngl buffer format reading the named fields of the record and skipping the others,
    e.g. vertex_format("position", "normal") == "3f 1x4 3f 1x4"."""
    return " ".join(f"{n}f" if field and field in names else f"{n}x4" for field, n in VERTEX_FIELDS)


VERTEX_FORMAT = vertex_format("position", "value", "normal")
"""The whole record as a moderngl buffer format."""

INDEX_BYTES = 12
"""One triangle: three uint32 vertex indices."""

STORAGE_OFFSET_ALIGNMENT = 256
"""Offsets at which a window of a mesh buffer is bound as a storage block: a multiple of every
GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT seen (16 to 256; moderngl does not report it)."""


def divisor_magic(d: int) -> tuple[int, int, int]:
    """(multiplier, shift 1, shift 2) with which mc_common.glsl's divide(n, magic) is n // d for
    every 32-bit n: Granlund and Montgomery, "Division by invariant integers using multiplication"
    (PLDI 1994), figure 4.1.  1 <= d < 2^32."""
    if not 1 <= d < 1 << 32:
        raise InputError(f"divisor {d} is outside 1 .. 2^32 - 1")
    bits = (d - 1).bit_length()  # ceil(log2 d)
    return ((1 << 32) * ((1 << bits) - d)) // d + 1, min(bits, 1), max(bits - 1, 0)


# --- binding slots --------------------------------------------------------------------------------
# Image units and storage-block bindings are set per dispatch: a slot means what the pass bound to it
# says, so one number serves several roles, never two in one shader (tests/core/test_layout.py checks
# each shader).  Python binds by these names and the shaders declare them by their #defines
# (UNIT_<NAME> for images, BLOCK_<NAME> for storage blocks): no shader spells a binding number.


class ImageUnit:
    """Image units of the compute passes (`layout(binding = UNIT_...)`)."""
    VOLUME = 0  # the resident volume (mc_common.glsl): every pass that samples it
    # extraction (mc_*, mt_*)
    SIGN_WORDS = 1
    WORD_COUNTS = 2
    WORD_OFFSETS = 3
    CASE_TABLE = 5
    # smoothing (smooth_*)
    POSITIONS = 1  # where the vertices are (ping-pong: the iteration's input)
    MOVED = 2  # smooth_step's proposed moves
    NEIGHBOURS = 3
    RINGS = 4
    CURVATURES = 5
    RANKS = 5
    NEXT_POSITIONS = 6  # smooth_keep's output


class StorageBlock:
    """Storage-block bindings of the compute passes (`layout(std430, binding = BLOCK_...)`)."""
    # the exclusive scan (scan_*)
    SCAN_DATA = 0
    SCAN_SUMS = 1
    # the mesh, as the extraction writes it and smoothing and sharp features read it
    MESH_INDICES = 6
    MESH_VERTICES = 8
    # extraction (mc_*, mt_*)
    BRICK_VERTICES = 1  # per brick: vertex counts, scanned in place into offsets
    BRICK_TRIANGLES = 2
    BRICK_STATES = 3
    VERTEX_JOBS = 4
    ACTIVE_BRICKS = 7
    BRICK_RANGES = 8
    DISPATCH_ARGS = 9
    BRICK_OWN_VERTICES = 5  # the trilinear topology's: per brick, its cells' own vertices, scanned
    OWN_JOBS = 3  # the trilinear topology's own-vertex jobs (mc3_triangles.comp -> mc3_own_vertices.comp)
    # the resident volume's range pass (mc_row_range, mc_brick_range)
    NON_FINITE = 7
    ROW_RANGES = 9
    # smoothing
    ENDS = 2
    # sharp features (emc_*)
    PATCH_MEMBERS = 1
    RING_MEMBERS = 2
    CELLS = 3
    POINTS = 4
    # an expression volume sampled on the GPU (expr_sample.comp, gpu/expression.py)
    EXPR_SAMPLES = 0
    EXPR_INPUTS = 1
    FLAGS = 5


def binding_defines() -> dict[str, int]:
    """The binding slots as #defines: UNIT_VOLUME, BLOCK_BRICK_RANGES, ..."""
    return {f"{prefix}_{name}": value for prefix, slots in (("UNIT", ImageUnit), ("BLOCK", StorageBlock))
            for name, value in vars(slots).items() if name.isupper()}


def shader_defines() -> dict[str, object]:
    """The layout constants as GLSL `#define`s (integer literals, so usable in layout qualifiers)."""
    return {
        **binding_defines(),
        "WORD_BITS": WORD_BITS,
        "BRICK_I": BRICK_I,
        "BRICK_J": BRICK_J,
        "BRICK_WORDS": BRICK_WORDS,
        "SAMPLES_PER_TEXEL": SAMPLES_PER_TEXEL,
        "EDGE_MARGIN": f"(1.0 / {int(round(1.0 / float(EDGE_MARGIN)))}.0)",
        "GROUP_SIZE": GROUP_SIZE,
        "SCAN_GROUP": SCAN_GROUP,
        "SCAN_ITEMS_PER_INVOCATION": SCAN_ITEMS_PER_INVOCATION,
        "SCAN_BLOCK": SCAN_BLOCK,
        "MAX_GROUPS_PER_DIMENSION": MAX_GROUPS_PER_DIMENSION,
        "VERTEX_FLOATS": VERTEX_FLOATS,
    }
