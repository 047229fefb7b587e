"""Hostile expr: input (issue 22): formulas as long or deep as the 2,000-character limit allows,
IEEE special cases where the GPU and numpy once disagreed, grids past the extractor's limit, and
boxes that overflow float32.  And 2,000 random formulas of the grammar, sampled by both back ends,
which must agree sample for sample, so a volume is accepted or refused alike everywhere.
"""
from __future__ import annotations

import random
import sys

import numpy as np
import pytest
from support.command import refused, succeeded

from isoscope.resources import shader_source
from isoscope.volumes import VolumeError, open_volume
from isoscope.volumes import expression as ex
from isoscope.volumes.expression import MAX_DEPTH, MAX_LENGTH, evaluate, parse, to_glsl
from isoscope.volumes.expression_volume import largest_cube_resolution
from isoscope.volumes.gpu_sampler import TooCostlyForGPU, sample_axis, sample_on_gpu
from isoscope.volumes.grid import Box, sample_function

sys.setrecursionlimit(1000)  # the default, whatever a plugin set: the point is not to need more


def chain(op: str, terms: int = 999, term: str = "x") -> str:
    return op.join([term] * terms)


# --- formulas as big as the length limit allows ------------------------------------------

@pytest.mark.parametrize("text, expected", [
    (chain("+"), lambda x: 999 * x),
    (chain("-"), lambda x: -997 * x),
    (chain("*", 999, "1"), lambda x: 1.0 + 0 * x),
    (chain("/", 999, "1"), lambda x: 1.0 + 0 * x),
    ("-" * 1999 + "x", lambda x: -x),
    ("-+" * 999 + "x", lambda x: -x),
    (chain("+", 332, "x*y"), lambda x: 332 * x * 0.5),
])
def test_the_longest_chains_evaluate_without_recursion(text, expected):
    assert len(text) <= MAX_LENGTH
    tree = parse(text)
    x = np.array([0.25, -1.0, 3.0], dtype=np.float32)
    np.testing.assert_allclose(evaluate(tree, x, 0.5, 0.0), expected(x).astype(np.float32), rtol=1e-5)
    assert to_glsl(tree).body.count(";") < 2 * len(text)


@pytest.mark.parametrize("text", [
    "(" * 999 + "x" + ")" * 999,
    "sin(" * 399 + "x" + ")" * 399,
    "x" + "^1" * 999,
    "2^(" * 300 + "x" + ")" * 300,
    "x" + "^x" * 999,
    "-(" * 600 + "x" + ")" * 600,
    "min(x, " * 200 + "x" + ")" * 200,
])
def test_deep_nesting_is_refused_in_one_line_naming_the_limit(text):
    assert len(text) <= MAX_LENGTH
    with pytest.raises(VolumeError, match=rf"more than {MAX_DEPTH} levels deep") as caught:
        parse(text)
    assert "\n" not in str(caught.value)


def test_nesting_up_to_the_limit_parses_evaluates_and_emits():
    for text in ["(" * MAX_DEPTH + "x" + ")" * MAX_DEPTH, "sin(" * MAX_DEPTH + "x" + ")" * MAX_DEPTH,
                 "x" + "^(x" * (MAX_DEPTH // 2) + ")" * (MAX_DEPTH // 2), "x" + "^-x" * MAX_DEPTH]:
        tree = parse(text)
        evaluate(tree, np.float32(0.5), 0, 0)
        to_glsl(tree)


def test_the_longest_chain_compiles_and_agrees_on_the_gpu(gl_ctx):
    tree = parse(chain("+") + "-" + chain("*", 1, "y"))
    box, shape = Box((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0)), (4, 3, 2)
    on_gpu = sample_on_gpu(tree, box, shape, ctx=gl_ctx)
    np.testing.assert_array_equal(on_gpu, sample_function(lambda x, y, z: evaluate(tree, x, y, z), box, shape))


def test_a_formula_too_costly_to_compile_is_sampled_with_numpy_or_refused_in_one_line(gl_ctx):
    text = chain("+", 399, "x^y")
    with pytest.raises(TooCostlyForGPU, match="too many operations"):
        sample_on_gpu(parse(text), Box.cube(-1.0, 1.0), (4, 4, 4), ctx=gl_ctx)
    volume = open_volume(f"expr:{text}; box=0.5,1; res=6", ctx=gl_ctx)
    assert any("sampled with numpy" in note for note in volume.notes)
    with pytest.raises(VolumeError, match="too many operations") as caught:
        open_volume(f"expr:{text}; box=0.5,1; res=6", ctx=gl_ctx, backend="gpu")
    assert "\n" not in str(caught.value)


# --- the command line, as a user runs it --------------------------------------------------

@pytest.mark.parametrize("formula, words", [
    ("(" * 999 + "x" + ")" * 999, ["column 52", f"more than {MAX_DEPTH} levels"]),
    ("sin(" * 399 + "x" + ")" * 399, [f"more than {MAX_DEPTH} levels"]),
])
def test_deep_formulas_are_refused_on_the_command_line(formula, words):
    refused(f"expr:{formula}", words=words)


def test_the_longest_chains_export_from_the_command_line(tmp_path):
    for op in "+*":
        run = succeeded("export", f"expr:{chain(op, 998)}-y; res=8", "--out", tmp_path / "m.stl", timeout=60)
        assert run.seconds < 30


def test_a_grid_past_the_extractor_limit_is_refused_before_sampling():
    assert largest_cube_resolution() == 1024
    refused("expr:x^2 + y^2 + z^2 - 0.5; res=1100", words=["1100x1100x1100", "2^30", "res=1024"], seconds=5)


@pytest.mark.parametrize("box, words", [
    ("-1e308,1e308", ["32-bit floats", "smaller box"]),
    ("-3e38,3e38", ["32-bit floats"]),
    ("1,1.00000001", ["empty in 32-bit floats"]),
    ("1e6,1.000001e6", ["too narrow for res=64"]),
    ("1,-1", ["lo < hi"]),
])
def test_a_box_that_does_not_fit_float32_is_refused_in_one_line(box, words):
    refused(f"expr:x; box={box}", words=words, seconds=5)


# --- IEEE special cases: the same samples on both back ends -------------------------------

SPECIAL = ["z + 0*log(x)", "x/0", "-x/0", "0/x", "x/x", "(0*x)^-1", "(0*x)^-3", "(0*x)^0.5", "1/(0*x)",
           "x - x + 1/x - 1/x", "sqrt(0*x)", "1/sqrt(-0*x)", "exp(1/(0*x))", "log(0*x) - log(0*x)",
           "min(0*x, -0*x)", "1/max(-0*x, 0*x)", "1/min(x*0, 0*x)", "x^(1/(0*y))", "(x*1e30)^2*1e-30",
           "(x*1e-20)*1e-20", "1/((x*1e-20)*1e-20)", "log(exp(-100 + 0*x))", "exp(-1/(x*x))", "1e38*10*x",
           "x^(y*1e30)", "(-1)^(y*1e30)", "(x-1)^(1/(y*0))", "sin(1/(0*x))", "tan(x/0)", "abs(-0*x)/x"]


def both(text, ctx, shape=(5, 3, 4)):
    tree, box = parse(text), Box((-2.0, -1.0, -1.5), (2.0, 1.0, 1.5))
    return (sample_on_gpu(tree, box, shape, ctx=ctx),
            sample_function(lambda x, y, z: evaluate(tree, x, y, z), box, shape))


def assert_alike(on_gpu, on_cpu, what, rtol=1e-5):
    """NaN in the same places; infinities and zeros bit for bit (their signs matter: 1/-0 is -Inf);
    other values within the few ulps by which sin, exp, log or pow may differ."""
    nan = np.isnan(on_cpu)
    np.testing.assert_array_equal(np.isnan(on_gpu), nan, err_msg=what)
    exact = ~nan & (np.isinf(on_cpu) | (on_cpu == 0) | np.isinf(on_gpu) | (on_gpu == 0))
    np.testing.assert_array_equal(on_gpu[exact].view(np.uint32), on_cpu[exact].view(np.uint32), err_msg=what)
    np.testing.assert_allclose(on_gpu[~nan & ~exact], on_cpu[~nan & ~exact], rtol=rtol, err_msg=what)


@pytest.mark.parametrize("text", SPECIAL)
def test_ieee_special_cases_agree(gl_ctx, text):
    assert_alike(*both(text, gl_ctx), text)


@pytest.mark.parametrize("text", ["z + 0*log(x)", "x/0", "1/(x - y)"])
def test_nonfinite_samples_are_refused_alike_by_both_back_ends(gl_ctx, text):
    messages = []
    for backend in ("gpu", "cpu"):
        with pytest.raises(VolumeError) as caught:
            open_volume(f"expr:{text}; res=9", ctx=gl_ctx, backend=backend)
        messages.append(str(caught.value))
    assert messages[0] == messages[1] and "\n" not in messages[0]


# --- 2,000 random formulas ----------------------------------------------------------------

NUMBERS = ["0", "1", "2", "3", "0.5", "0.1", "10", "100", "1e-3", "1e30", "1e-30", "pi", "7.25", "40"]
FUNCTIONS = ["sin", "cos", "tan", "exp", "log", "sqrt", "abs", "min", "max"]


def random_formula(rng: random.Random, depth: int) -> str:
    if depth == 0 or rng.random() < 0.2:
        return rng.choice(["x", "y", "z", "x", "y", "z", *NUMBERS])
    kind = rng.random()
    if kind < 0.45:
        op = rng.choice("+-*/^")
        right = (rng.choice(["2", "3", "0.5", "-1", "-2", "0", "x", "y", "1.5", "-0.5"])
                 if op == "^" and rng.random() < 0.6 else random_formula(rng, depth - 1))
        return f"({random_formula(rng, depth - 1)}) {op} ({right})"
    if kind < 0.55:
        return f"-({random_formula(rng, depth - 1)})"
    function = rng.choice(FUNCTIONS)
    args = [random_formula(rng, depth - 1) for _ in range(2 if function in ("min", "max") else 1)]
    return f"{function}({', '.join(args)})"


def gpu_batch(ctx, trees, points):
    """Every tree at every point, in one compute shader: row k of the result is tree k."""
    codes, first = [], 0
    for tree in trees:
        codes.append(to_glsl(tree, first_input=first))
        first += len(codes[-1].numbers)
    count = len(points[0])
    inputs = np.concatenate([*(code.numbers for code in codes), *points]).astype(np.float32)
    fields = "\n".join(f"float field{k}(float x, float y, float z) {{ {code.body} }}"
                       for k, code in enumerate(codes))
    calls = "\n".join(f"    samples[{k * count}u + i] = field{k}(x, y, z);" for k in range(len(codes)))
    source = f"""#version 430
layout(local_size_x = 64) in;
layout(std430, binding = 0) writeonly buffer Samples {{ float samples[]; }};
layout(std430, binding = 1) readonly buffer Inputs {{ float inputs[]; }};
{shader_source("expr_functions.glsl")}
{fields}
void main() {{
    uint i = gl_GlobalInvocationID.x;
    if (i >= {count}u) return;
    float x = inputs[{first}u + i], y = inputs[{first + count}u + i], z = inputs[{first + 2 * count}u + i];
{calls}
}}
"""
    program = ctx.compute_shader(source)
    out = ctx.buffer(reserve=len(codes) * count * 4)
    data = ctx.buffer(inputs.tobytes())
    try:
        out.bind_to_storage_buffer(0)
        data.bind_to_storage_buffer(1)
        program.run(-(-count // 64))
        ctx.memory_barrier()
        return np.frombuffer(out.read(), dtype=np.float32).reshape(len(codes), count)
    finally:
        out.release()
        data.release()
        program.release()


def _perturbed(seed: int):
    """numpy's evaluate with every transcendental result moved by about the error a GPU's (or
    numpy's own) implementation may make: all up (seed 0), all down (1), or up or down at random."""
    rng = np.random.default_rng(seed)

    def nudge(function, size):
        def nudged(*args):
            result = np.asarray(function(*args))
            direction = (np.array([1.0, -1.0])[seed] if seed < 2
                         else rng.choice(np.array([-1.0, 1.0]), size=result.shape))
            with np.errstate(all="ignore"):
                moved = result + direction * size(result, *args)
            return np.where(np.isfinite(result) & np.isfinite(moved), moved, result).astype(np.float32)
        return nudged

    big = lambda a: np.maximum(1.0, np.abs(np.nan_to_num(a)))  # noqa: E731
    functions = dict(ex._NUMPY_FUNCTIONS)
    functions.update({
        "sin": nudge(np.sin, lambda r, a: 1e-6 * big(a)),
        "cos": nudge(np.cos, lambda r, a: np.where(a == 0, 0, 1e-6 * big(a))),
        "tan": nudge(np.tan, lambda r, a: 1e-6 * big(a) * (1 + r * r)),
        "exp": nudge(np.exp, lambda r, a: np.where(a == 0, 0, 1e-6 * big(a) * np.abs(r))),
        "log": nudge(np.log, lambda r, a: np.where(a == 1, 0, 1e-6 * big(r))),
    })
    operators = dict(ex._NUMPY_OPERATORS)
    operators["^"] = nudge(ex._power, lambda r, a, b: np.where(
        np.isin(b, (0, 1, 2, -1)) | (a == 0) | (a == 1), 0,
        1e-6 * big(np.asarray(b) * np.log2(np.abs(np.where(a == 0, 1, a)))) * np.abs(r)))
    return functions, operators


GPU_ERROR = 2e-6  # what a GPU's sin, exp, log, pow may be off by, relative to max(1, |argument|) and |result|


def error_bound(tree, x, y, z):
    """Per sample, a first-order bound on how far a GPU's float32 result may be from numpy's:
    +, -, *, /, sqrt, abs, min, max are exact on both, so only the transcendental functions
    (and pow) err, and their errors spread through the operations that follow."""
    big = lambda a: np.maximum(1.0, np.abs(a))  # noqa: E731
    points = [np.asarray(v, dtype=np.float64) for v in (x, y, z)]
    stack = []
    with np.errstate(all="ignore"):
        for node in ex.postorder(tree):
            if isinstance(node, ex.Number):
                stack.append((np.float64(np.float32(node.value)), 0.0))
            elif isinstance(node, ex.Variable):
                stack.append((points["xyz".index(node.name)], 0.0))
            elif isinstance(node, ex.Unary):
                v, e = stack.pop()
                stack.append((-v, e))
            elif isinstance(node, ex.Binary):
                (b, eb), (a, ea) = stack.pop(), stack.pop()
                if node.op in "+-":
                    v, e = (a + b if node.op == "+" else a - b), ea + eb
                elif node.op == "*":
                    v, e = a * b, np.abs(b) * ea + np.abs(a) * eb + ea * eb
                elif node.op == "/":
                    v = a / b
                    e = np.where(np.abs(b) > eb, (ea + np.abs(v) * eb) / (np.abs(b) - eb), np.inf)
                else:
                    v = np.power(a, b)
                    exact = np.isin(b, (0, 1, 2, -1)) | (a == 0) | (a == 1)
                    own = np.where(exact, 0.0, GPU_ERROR * big(b * np.log2(np.abs(a))) * np.abs(v))
                    e = own + np.abs(v) * (np.abs(b / a) * ea + np.abs(np.log(np.abs(a))) * eb)
                stack.append((v, e))
            else:
                args = [stack.pop() for _ in node.args][::-1]
                (a, ea), f = args[0], node.function
                if f in ("min", "max"):
                    (b, eb) = args[1]
                    stack.append(((np.minimum if f == "min" else np.maximum)(a, b), np.maximum(ea, eb)))
                    continue
                v = getattr(np, f)(a)
                own = np.where(a == 0, 0.0, GPU_ERROR * big(a))
                e = {"sin": ea + own, "cos": ea + own, "tan": (1 + v * v) * (ea + own),
                     "exp": np.abs(v) * (ea + own), "log": ea / np.abs(a) + np.where(a == 1, 0.0, GPU_ERROR * big(v)),
                     "sqrt": ea / (2 * np.abs(v)), "abs": ea}[f]
                stack.append((v, e))
    return np.nan_to_num(stack[0][1], nan=np.inf)


def classify(values):
    return np.select([np.isnan(values), np.isposinf(values), np.isneginf(values)], [1, 2, 3], 0)


def test_2000_random_formulas_agree_on_both_back_ends(gl_ctx, monkeypatch):
    rng = random.Random(22)
    texts = [random_formula(rng, rng.choice((1, 2, 3, 3, 4))) for _ in range(2000)]
    trees = [parse(text) for text in texts]
    box, shape = Box((-2.0, -1.0, -3.0), (2.0, 1.0, 0.5)), (5, 5, 8)  # 0, +-0.5, +-1, +-2 on the grid
    axes = np.meshgrid(*(sample_axis(box, a, n) for a, n in enumerate(shape)), indexing="ij")
    points = [a.ravel() for a in axes]

    on_cpu = np.stack([np.broadcast_to(evaluate(tree, *points), points[0].shape) for tree in trees])
    envelope = []
    for seed in range(4):
        functions, operators = _perturbed(seed)
        monkeypatch.setattr(ex, "_NUMPY_FUNCTIONS", functions)
        monkeypatch.setattr(ex, "_NUMPY_OPERATORS", operators)
        envelope.append(np.stack([np.broadcast_to(evaluate(tree, *points), points[0].shape) for tree in trees]))
    monkeypatch.undo()
    on_gpu = np.concatenate([gpu_batch(gl_ctx, trees[i:i + 8], points) for i in range(0, len(trees), 8)])

    # A sample whose class moves when the transcendental functions move by their error can
    # legitimately differ (1/sin(pi) is finite or Inf depending on sin's last bit): skipped.
    # Finite samples must agree within the error those functions may spread (error_bound).
    kind = classify(on_cpu)
    bound = np.stack([np.broadcast_to(error_bound(tree, *points), points[0].shape) for tree in trees])
    with np.errstate(all="ignore"):
        stable = (np.all([classify(moved) == kind for moved in envelope], axis=0)
                  & ((kind != 0) | (bound <= 1e-2 * np.maximum(1.0, np.abs(on_cpu)))))
    assert stable.mean() > 0.9, f"only {stable.mean():.1%} of the samples are well-conditioned"
    nonfinite = (kind != 0) & stable
    assert nonfinite.mean() > 0.1, "the formulas should exercise NaN and Inf"

    failures = []
    for k, text in enumerate(texts):
        gpu, cpu, keep = on_gpu[k], on_cpu[k], stable[k]
        finite = keep & (kind[k] == 0)
        with np.errstate(all="ignore"):
            tolerance = 2 * bound[k] + 4 * np.spacing(np.abs(cpu).astype(np.float32)) + 1e-30
            wrong = (keep & (classify(gpu) != kind[k])) | (finite & ~(np.abs(gpu - cpu) <= tolerance))
        if wrong.any():
            i = int(np.argmax(wrong))
            failures.append(f"{text!r} at {[float(p[i]) for p in points]}: gpu {gpu[i]!r}, numpy {cpu[i]!r}")
        # the volume check refuses a formula with any non-finite sample: alike on both
        if keep.all():
            assert np.isfinite(gpu).all() == np.isfinite(cpu).all(), text
    assert not failures, f"{len(failures)} of {len(texts)} formulas disagree, e.g.\n" + "\n".join(failures[:15])


@pytest.mark.parametrize("text", [
    "exp(88.7 + 0.05*x)", "exp(-87.3 + 0.05*x)", "2^(128 + 0.01*x)", "2^(-126 + 0.01*x)", "(2 + x*0.001)^127.9",
    "10^(38.5 + x*0.1)", "1/(1e38*(1 + x))", "(x*1e19)*(x*1e19)", "(x*1e-19)*(x*1e-19)", "log(x*1e-37)",
    "tan(1.5707963 + x*1e-7)",
])
def test_overflow_and_underflow_thresholds_agree(gl_ctx, text):
    """Across the float32 overflow and normal-underflow thresholds, in 2001 steps: Inf, 0 and
    finite samples in the same places on both back ends."""
    tree, box, shape = parse(text), Box((-1.0, 0.0, 0.0), (1.0, 1.0, 1.0)), (2001, 2, 2)
    on_gpu = sample_on_gpu(tree, box, shape, ctx=gl_ctx)
    on_cpu = sample_function(lambda x, y, z: evaluate(tree, x, y, z), box, shape)
    assert_alike(on_gpu, on_cpu, text, rtol=1e-4)  # pow near 2^128: exp2(b*log2(a)) loses ~|b*log2(a)| ulps


def test_deep_formulas_are_evaluated_a_few_planes_at_a_time(monkeypatch):
    from isoscope.volumes import expression_volume
    text = "x*y + (" * 40 + "z" + ")" * 40
    assert ex.peak_intermediates(parse(text)) >= 40
    whole = open_volume(f"expr:{text}; res=12", backend="cpu").data
    monkeypatch.setattr(expression_volume, "_EVALUATION_BYTES", 12 * 12 * 4 * 45)  # about one plane at a time
    np.testing.assert_array_equal(open_volume(f"expr:{text}; res=12", backend="cpu").data, whole)
