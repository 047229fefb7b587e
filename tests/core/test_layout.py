"""core/layout.py is the one place the shaders' layout numbers are written: they reach every
compute program as #defines, and no marching-cubes or scan shader spells one as a literal, nor any
compute shader a binding slot."""
from __future__ import annotations

import re

import numpy as np
import pytest

from isoscope.core import layout
from isoscope.gpu.programs import compute_program
from isoscope.resources import shader_source, shaders_dir

LAYOUT_SHADERS = sorted(p.name for p in shaders_dir().iterdir() if p.name.startswith(("mc_", "scan_")))
# Numbers that are layout constants here: word bits, group sizes, scan block, dispatch limit, 1/256.
LITERAL = re.compile(r"\b(32|64|128|256|1024|65535)u?\b|\b\d+\.0\s*/\s*256\.0")


def code_of(name: str) -> str:
    """The shader without its comments."""
    text = (shaders_dir() / name).read_text()
    return re.sub(r"//[^\n]*|/\*.*?\*/", "", text, flags=re.S)


@pytest.mark.parametrize("name", LAYOUT_SHADERS)
def test_no_layout_number_is_spelled_as_a_literal(name):
    code = code_of(name).replace("#version 430", "")
    if name == "mc_case_table.glsl":  # 256 cases is the cube's 2^8 corner signs, not a layout choice
        code = code.replace("256u * MAX_TRIANGLES_PER_CELL", "")
    assert not LITERAL.findall(code), f"{name}: use the #define from app/layout.py"


def test_the_check_catches_a_literal(tmp_path):
    assert LITERAL.search("layout(local_size_x = 64) in;") and LITERAL.search("EDGE_MARGIN = 1.0 / 256.0")
    assert not LITERAL.search("layout(r32ui, binding = 1) uniform uimage2D u; rgba32f")


def test_every_program_sees_the_layout_as_python_has_it(gl_ctx, tmp_path, monkeypatch):
    names = ["WORD_BITS", "BRICK_I", "BRICK_J", "BRICK_WORDS", "SAMPLES_PER_TEXEL", "GROUP_SIZE",
             "SCAN_GROUP", "SCAN_ITEMS_PER_INVOCATION", "SCAN_BLOCK", "MAX_GROUPS_PER_DIMENSION", "VERTEX_FLOATS"]
    body = "\n".join(f"    values[{i}] = uint({name});" for i, name in enumerate(names))
    (tmp_path / "probe.comp").write_text(
        "#version 430\nlayout(local_size_x = 1) in;\n"
        f"layout(std430, binding = 0) writeonly buffer Out {{ uint values[{len(names)}]; float margin; }};\n"
        f"void main() {{\n{body}\n    margin = EDGE_MARGIN;\n}}\n")
    monkeypatch.setattr("isoscope.resources.shaders_dir", lambda: tmp_path)
    program = compute_program(gl_ctx, "probe.comp")
    out = gl_ctx.buffer(reserve=4 * (len(names) + 1))
    out.bind_to_storage_buffer(0)
    program.run(1)
    data = np.frombuffer(out.read(), np.uint32)
    out.release()
    assert dict(zip(names, data[:-1].tolist())) == {name: getattr(layout, name) for name in names}
    assert data[-1:].view(np.float32)[0] == layout.EDGE_MARGIN


def emulated_divide(n: np.ndarray, magic) -> np.ndarray:
    """mc_common.glsl's divide(), in uint64 arithmetic: (high + ((n - high) >> s1)) >> s2."""
    m, s1, s2 = (np.uint64(v) for v in magic)
    high = (n * m) >> np.uint64(32)
    return (high + ((n - high) >> s1)) >> s2


def test_divisor_magic_divides_every_32_bit_number_exactly():
    rng = np.random.default_rng(11)
    divisors = list(range(1, 2049)) + [2**k + e for k in range(11, 32) for e in (-1, 0, 1)] + [2**32 - 1]
    for d in divisors:
        multiples = rng.integers(0, 2**32 // d, 1000, dtype=np.uint64) * np.uint64(d)
        n = np.concatenate([multiples, multiples + np.uint64(d - 1), rng.integers(0, 2**32, 500, dtype=np.uint64),
                            np.array([0, 1, 2**31, 2**32 - 1], np.uint64)])
        n = n[n < 2**32]
        assert np.array_equal(emulated_divide(n, layout.divisor_magic(d)), n // np.uint64(d)), d
    with pytest.raises(ValueError):
        layout.divisor_magic(0)


# -- binding slots ----------------------------------------------------------------------------------
BINDING = re.compile(r"layout\s*\(([^)]*)\)\s*(?:readonly\s+|writeonly\s+|coherent\s+|restrict\s+)*"
                     r"(buffer|uniform)\s+(\w+)(?:\s+(\w+))?")
SLOT = re.compile(r"binding\s*=\s*(\w+)")


def compute_shaders() -> list[str]:
    return sorted(p.name for p in shaders_dir().iterdir() if p.suffix == ".comp")


def declared_slots(source: str) -> list[tuple[str, str, str]]:
    """(kind "image" or "block", slot as written, declared name) of each binding in `source`."""
    out = []
    for qualifiers, storage, type_or_block, name in BINDING.findall(source):
        slot = SLOT.search(qualifiers)
        if slot:
            kind = "block" if storage == "buffer" else "image"
            out.append((kind, slot.group(1), type_or_block if storage == "buffer" else name))
    return out


def test_the_slot_names_are_the_defines_every_program_gets():
    defines = layout.shader_defines()
    assert defines["UNIT_VOLUME"] == layout.ImageUnit.VOLUME == 0
    assert defines["BLOCK_BRICK_RANGES"] == layout.StorageBlock.BRICK_RANGES
    assert layout.binding_defines().items() <= defines.items()


@pytest.mark.parametrize("name", sorted(p.name for p in shaders_dir().iterdir()))
def test_no_shader_spells_a_binding_number(name):
    assert not re.search(r"binding\s*=\s*\d", code_of(name)), f"{name}: bind by a UNIT_/BLOCK_ name of core/layout.py"


def test_the_binding_check_reads_what_the_shaders_declare():
    source = ("layout(std430, binding = BLOCK_MESH_VERTICES) readonly buffer Vertices { float v[]; };\n"
              "layout(rgba32f, binding = UNIT_MOVED) writeonly uniform image2D u_after;")
    assert declared_slots(source) == [("block", "BLOCK_MESH_VERTICES", "Vertices"), ("image", "UNIT_MOVED", "u_after")]
    assert re.search(r"binding\s*=\s*\d", "layout(std430, binding = 3) buffer B { uint b[]; };")


@pytest.mark.parametrize("name", compute_shaders())
def test_each_pass_binds_every_slot_by_a_known_name_and_no_number_twice(name):
    """Slots are reused between passes (core/layout.py): within one program, with its includes,
    every binding is a name layout.py defines, and no two images or two blocks share a number."""
    defines = layout.binding_defines()
    slots = declared_slots(re.sub(r"//[^\n]*", "", shader_source(name)))
    assert slots, name
    for kind, prefix in (("image", "UNIT_"), ("block", "BLOCK_")):
        named = [slot for k, slot, _ in slots if k == kind]
        assert all(slot.startswith(prefix) and slot in defines for slot in named), (name, named)
        numbers = [defines[slot] for slot in named]
        assert len(numbers) == len(set(numbers)), f"{name}: two {kind}s at one slot: {named}"
