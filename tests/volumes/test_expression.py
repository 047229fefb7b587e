"""The expression language: grammar, numpy evaluation, and GPU sampling that agrees with numpy."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

from isoscope.volumes import VolumeError, open_volume
from isoscope.volumes.expression import GLSL_FUNCTIONS, GLSL_OPERATORS, evaluate, parse, to_glsl
from isoscope.volumes.expression_volume import split_expression_spec
from isoscope.volumes.gpu_sampler import sample_on_gpu
from isoscope.volumes.grid import Box, sample_function


def value(text, x=0.3, y=-0.7, z=1.9):
    return float(evaluate(parse(text), x, y, z, dtype=np.float64))


@pytest.mark.parametrize("text, expected", [
    # Python's own arithmetic is the reference for precedence and associativity.
    ("1 + 2 * 3", 1 + 2 * 3),
    ("(1 + 2) * 3", (1 + 2) * 3),
    ("2 ^ 3 ^ 2", 2 ** 3 ** 2),
    ("-2 ^ 2", -2 ** 2),
    ("2 ^ -1", 2 ** -1),
    ("8 / 4 / 2", 8 / 4 / 2),
    ("7 - 3 - 2", 7 - 3 - 2),
    ("--3", 3),
    ("+x", 0.3),
    (".5e1 + 1.", 6.0),
    ("x + 2*y - 3*z + 1", 0.3 + 2 * -0.7 - 3 * 1.9 + 1),
    ("min(x, y) * max(x, z)", min(0.3, -0.7) * max(0.3, 1.9)),
    ("sqrt(abs(y)) + log(z) + exp(x) + tan(x) + sin(pi*y) + cos(z)",
     math.sqrt(0.7) + math.log(1.9) + math.exp(0.3) + math.tan(0.3) + math.sin(math.pi * -0.7) + math.cos(1.9)),
])
def test_numpy_evaluation_follows_ordinary_arithmetic(text, expected):
    assert value(text) == pytest.approx(expected, rel=1e-12)


def test_evaluation_broadcasts_over_a_grid_with_axis_0_as_x():
    axis = np.linspace(-1, 1, 5)
    x, y, z = axis[:, None, None], axis[None, :, None], axis[None, None, :]
    grid = evaluate(parse("x - 10*y + 100*z"), x, y, z)
    assert grid.shape == (5, 5, 5)
    assert grid[4, 0, 0] - grid[0, 0, 0] == pytest.approx(2.0)


@pytest.mark.parametrize("text", [
    "x; } void main() { }",      # GLSL injection: ';' '{' are not tokens
    "x // comment",
    "#define x 1",
    "__import__('os')",
    "x.real",
    "x ** 2",
    "lambda: 1",
    "y[0]",
])
def test_text_outside_the_grammar_is_refused(text):
    with pytest.raises(VolumeError, match="expression error at column"):
        parse(text)


def test_glsl_is_built_only_from_whitelisted_pieces():
    code = to_glsl(parse("sin(x)^2 + max(y, -z) / 1e-3 + pi - log(2.5e-7) + 0*x"))
    # the numbers travel as data, never as text: inputs[i] holds the float32 evaluate() uses
    assert code.numbers.dtype == np.float32
    assert set(code.numbers) == {np.float32(v) for v in (2, 1e-3, math.pi, 2.5e-7, 0)}
    without_indices = re.sub(r"(inputs\[|\bt)\d+", " ", code.body)
    assert not re.search(r"\d", without_indices)
    identifiers = set(re.findall(r"[A-Za-z_]\w*", without_indices))
    assert identifiers <= ({"x", "y", "z", "inputs", "precise", "float", "return"}
                           | set(GLSL_FUNCTIONS.values()) | set(GLSL_OPERATORS.values()) | {"ex_neg"})
    assert set(re.sub(r"[\w\s]", "", code.body)) <= set("(),;=[]")


def test_spec_options():
    formula, box, resolution = split_expression_spec("expr: x*y ; box=-2,3 ; res=17")
    assert formula == "x*y" and resolution == "17"
    assert box == Box((-2.0, -2.0, -2.0), (3.0, 3.0, 3.0))
    _, box, _ = split_expression_spec("expr:x;box=0,1,2,3,4,5")
    assert box == Box((0.0, 2.0, 4.0), (1.0, 3.0, 5.0))
    for bad in ("expr:x;box=1,0", "expr:x;box=a,b", "expr:x;colour=red", "expr:x;box=1,2,3"):
        with pytest.raises(VolumeError):
            split_expression_spec(bad)


def test_expression_volume_matches_the_plane_builtin():
    plane = open_volume("plane:16")
    typed = open_volume("expr:x + 2*y - 3*z + 1; res=16", backend="cpu")
    np.testing.assert_allclose(typed.data, plane.data, atol=1e-6)
    assert typed.gradient_direction == "ascent" and typed.default_level == 0.0
    assert typed.spacing == pytest.approx(plane.spacing)


GPU_FORMULAS = [
    "x + 2*y - 3*z + 1",
    "sin(3*x)*cos(2*y) + sin(2*y)*cos(3*z) + sin(3*z)*cos(3*x)",
    "sqrt(x^2 + y^2 + z^2) - 0.7",
    "(sqrt(x^2 + y^2) - 0.6)^2 + z^2 - 0.04",
    "exp(-4*(x^2 + y^2)) - abs(z) + tan(0.5*x)",
    "min(max(x, y), z) + log(z + 2) - 1/(x + 3)",
    "(-2)^3 * x^-2 + (y + 2)^0.5",
    # undefined maths: the NaN/Inf samples must land in the same places on both back ends
    "log(x)", "sqrt(y)", "1/x", "x^0.5", "(x - 0.5)^(-1)", "max(log(x), y)", "0^x",
]


@pytest.mark.parametrize("text", GPU_FORMULAS)
def test_gpu_sampling_agrees_with_numpy(gl_ctx, text):
    tree = parse(text)
    box, shape = Box((-1.0, -0.9, -0.8), (1.0, 1.1, 1.2)), (11, 9, 13)  # distinct axes: catches mix-ups
    on_gpu = sample_on_gpu(tree, box, shape, ctx=gl_ctx)
    on_cpu = sample_function(lambda x, y, z: evaluate(tree, x, y, z), box, shape)
    np.testing.assert_array_equal(np.isnan(on_gpu), np.isnan(on_cpu))
    np.testing.assert_array_equal(np.isposinf(on_gpu), np.isposinf(on_cpu))
    np.testing.assert_array_equal(np.isneginf(on_gpu), np.isneginf(on_cpu))
    finite = np.isfinite(on_cpu)
    np.testing.assert_allclose(on_gpu[finite], on_cpu[finite], rtol=1e-5, atol=1e-5)


def test_gpu_sampling_in_slabs_matches_one_pass(gl_ctx, monkeypatch):
    from isoscope.gpu import expression
    tree = parse("sin(5*x) + y*z")
    box, shape = Box.cube(-1.0, 1.0), (20, 16, 12)
    whole = sample_on_gpu(tree, box, shape, ctx=gl_ctx)
    monkeypatch.setattr(expression, "_SLAB_BYTES", 16 * 12 * 4 * 3)  # 3 planes per slab, 7 slabs
    calls = []
    slabbed = sample_on_gpu(tree, box, shape, ctx=gl_ctx, progress=lambda f, m: calls.append(f))
    np.testing.assert_array_equal(slabbed, whole)
    assert len(calls) == 7 and calls == sorted(calls) and calls[-1] == 1.0


def test_open_volume_samples_on_the_gpu_by_default(gl_ctx):
    volume = open_volume("expr:x^2 + y^2 + z^2 - 0.5; res=12", ctx=gl_ctx)
    reference = open_volume("expr:x^2 + y^2 + z^2 - 0.5; res=12", backend="cpu")
    assert not volume.notes  # no fallback happened
    np.testing.assert_allclose(volume.data, reference.data, rtol=1e-5, atol=1e-6)
