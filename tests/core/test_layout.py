"""gpu_layout.py is the one place the shaders' layout numbers are written: they reach every
compute program as #defines, and no marching-cubes or scan shader spells one as a literal."""
from __future__ import annotations

import re

import numpy as np
import pytest

from isoscope.core import layout as gpu_layout
from isoscope.gpu.programs import compute_program
from isoscope.resources import shaders_dir

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
    assert not LITERAL.findall(code), f"{name}: use the #define from app/gpu_layout.py"


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
    assert dict(zip(names, data[:-1].tolist())) == {name: getattr(gpu_layout, name) for name in names}
    assert data[-1:].view(np.float32)[0] == gpu_layout.EDGE_MARGIN


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
        assert np.array_equal(emulated_divide(n, gpu_layout.divisor_magic(d)), n // np.uint64(d)), d
    with pytest.raises(ValueError):
        gpu_layout.divisor_magic(0)
