"""`expr:FORMULA[; box=...][; res=N]` specs: parse the spec, sample the formula, check the result.

The object is where the formula is negative (an implicit surface F = 0 with
F < 0 inside, the usual convention for implicit surfaces and level sets), so the gradient direction is "ascent" and
the first level is 0.
"""
from __future__ import annotations

import numpy as np

from isoscope.core.layout import MAX_WORDS, WORD_BITS, fits_one_extraction

from ..errors import InputError
from .errors import VolumeError
from .expression import FLOAT32_MAX, evaluate, parse, peak_intermediates
from .grid import Box, pick_resolution, sample_function
from .volume import Progress, Volume, finish_volume

PREFIX = "expr:"
DEFAULT_BOX = Box.cube(-1.0, 1.0)
DEFAULT_RESOLUTION = 64
_OPTIONS_HELP = "use box=LO,HI or box=X0,X1,Y0,Y1,Z0,Z1 and res=N"
# The numpy back end evaluates a few axis-0 planes at a time so that all the intermediate
# values a formula holds at once (expression.peak_intermediates) stay under this.
_EVALUATION_BYTES = 64 << 20


def largest_cube_resolution() -> int:
    """The largest res=N whose N^3 grid the extractor takes (1024)."""
    n = 1
    while fits_one_extraction((n + 1,) * 3):
        n += 1
    return n


def check_grid_size(shape) -> None:
    """Refuse, before any allocation or sampling, a grid the extractor would refuse after it."""
    if not fits_one_extraction(shape):
        samples = int(np.prod([int(n) for n in shape], dtype=np.int64))
        limit = MAX_WORDS * WORD_BITS
        raise VolumeError(
            f"expr: res={shape[0]} makes {'x'.join(map(str, shape))} = {samples:,} samples, above the "
            f"extractor's limit of 2^{limit.bit_length() - 1} ({limit:,}); "
            f"use res={largest_cube_resolution()} or less")


def split_expression_spec(spec: str) -> tuple[str, Box, str | None]:
    """'expr:x*y; box=-2,2; res=96' -> ('x*y', Box, '96'). ';' is not in the grammar, so it is safe."""
    formula, *options = spec[len(PREFIX):].split(";")
    box, resolution = DEFAULT_BOX, None
    for option in options:
        if not option.strip():
            continue
        key, sep, value = (part.strip() for part in option.partition("="))
        key = key.lower()
        if not sep or key not in ("box", "res", "resolution"):
            raise VolumeError(f"unknown expr option {option.strip()!r}; {_OPTIONS_HELP}")
        if key == "box":
            box = _parse_box(value)
        else:
            resolution = value
    return formula.strip(), box, resolution


def _parse_box(text: str) -> Box:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) == 2:
        values = values * 3
    if len(values) != 6 or not all(np.isfinite(values)) or any(
            values[2 * a] >= values[2 * a + 1] for a in range(3)):
        raise VolumeError(f"expr box {text!r} is not valid; {_OPTIONS_HELP} with each LO < HI")
    # The formula is computed in 32-bit floats: the corners and the extent must be finite there
    # (checked in float64, before numpy could warn about an overflowing cast).
    for a in range(3):
        lo, hi = values[2 * a], values[2 * a + 1]
        if max(abs(lo), abs(hi)) > FLOAT32_MAX or hi - lo > FLOAT32_MAX:
            raise VolumeError(f"expr box {text!r} does not fit 32-bit floats (largest {FLOAT32_MAX:.4g}, "
                              f"extent included); use a smaller box")
        if np.float32(lo) >= np.float32(hi):
            raise VolumeError(f"expr box {text!r} is empty in 32-bit floats ({lo:g} and {hi:g} round to "
                              f"the same number); use a wider box")
    return Box(tuple(values[0::2]), tuple(values[1::2]))


def _check_samples_distinct(box: Box, shape) -> None:
    """Refuse a box so narrow for its position that neighbouring samples share a 32-bit coordinate."""
    from .gpu_sampler import sample_axis
    for axis, n in enumerate(shape):
        coordinates = sample_axis(box, axis, n)
        if not np.all(np.diff(coordinates) > 0):
            raise VolumeError(f"expr box is too narrow for res={n} at {box.lo[axis]:g}: neighbouring samples "
                              f"round to the same 32-bit coordinate; use a wider box or a lower res")


def open_expression(spec: str, *, resolution=None, progress: Progress | None = None,
                    backend: str = "auto", ctx=None) -> Volume:
    """The volume of an ``expr:`` spec: the formula parsed first (a typo costs no GL work), then sampled on an N^3 grid
    over its box on the GPU or with numpy; a formula that gives no finite value somewhere is refused, naming the place.
    """
    formula, box, spec_resolution = split_expression_spec(spec)
    tree = parse(formula)  # before any GL work: a typo costs nothing
    n = pick_resolution(spec_resolution, resolution, DEFAULT_RESOLUTION, "expr")
    shape = (n, n, n)
    check_grid_size(shape)
    _check_samples_distinct(box, shape)
    data, notes = _sample(tree, box, shape, backend, ctx, progress)
    spacing = box.spacing(shape)

    def where(index) -> str:
        """The world point of sample `index`, and what to do, for the refusal of a formula with no finite value there.
        """
        x, y, z = (box.lo[a] + index[a] * spacing[a] for a in range(3))
        return (f"at x={x:.4g}, y={y:.4g}, z={z:.4g} (e.g. log or sqrt of a negative number, "
                f"division by zero, overflow); change the formula or the box")

    name = formula if len(formula) <= 40 else formula[:37] + "..."
    return finish_volume(data, spacing=spacing, name=name, source=spec, gradient_direction="ascent",
                         default_level=0.0, notes=notes, what=f"expression {name!r}",
                         progress=progress, where=where)


def _sample(tree, box: Box, shape, backend: str, ctx, progress):
    if backend not in ("auto", "gpu", "cpu"):
        raise InputError(f"backend must be 'auto', 'gpu' or 'cpu', not {backend!r}")
    if backend != "cpu":
        from isoscope.gpu.context import REQUIRED_GL, GLUnavailable, current_or_standalone, version_text

        from .gpu_sampler import TooCostlyForGPU, sample_on_gpu
        try:
            if ctx is not None and ctx.version_code < REQUIRED_GL:   # a 4.1 window's (macOS): no compute
                raise GLUnavailable(f"the OpenGL context here is {version_text(ctx.version_code)}, with no "
                                    "compute shaders")
            return sample_on_gpu(tree, box, shape, ctx=ctx, progress=progress), []
        except GLUnavailable as exc:
            if backend == "gpu":
                raise VolumeError(f"cannot sample on the GPU: {exc}; use the cpu backend") from None
            note = ("no GPU context; the expression was sampled with numpy" if not _has_gl(current_or_standalone)
                    else "no OpenGL 4.3 compute shaders here; the expression was sampled with numpy")
        except TooCostlyForGPU:
            if backend == "gpu":
                raise
            note = "the formula is too long to compile for the GPU quickly; it was sampled with numpy (the same values)"
        except VolumeError:
            raise
        except Exception as exc:  # a driver failure must not cost the user their volume
            if backend == "gpu":
                raise VolumeError(f"GPU sampling failed ({type(exc).__name__}: {exc}); "
                                  f"use the cpu backend") from None
            note = f"GPU sampling failed ({type(exc).__name__}); the expression was sampled with numpy"
    else:
        note = None
    data = sample_function(_evaluator(tree, shape), box, shape, what="the expression", progress=progress)
    return data, [note] if note else []


def _has_gl(current_or_standalone) -> bool:
    """Whether any context (4.1 for drawing at least) can be had: which note an expression sampled in numpy gets."""
    from isoscope.gpu.context import DRAWING_GL, GLUnavailable
    try:
        current_or_standalone(DRAWING_GL)
        return True
    except GLUnavailable:
        return False


def _evaluator(tree, shape):
    """evaluate(tree, ...) a few axis-0 planes at a time: a formula that holds many grid-sized
    intermediate values at once (deep parentheses) must not hold them for a whole slab."""
    plane_bytes = int(shape[1]) * int(shape[2]) * 4
    planes = max(1, _EVALUATION_BYTES // (plane_bytes * (peak_intermediates(tree) + 2)))

    def fn(x, y, z):
        """The formula on the grid (x, y, z), evaluated a few planes of x at a time so that its intermediates stay
        within memory."""
        if len(x) <= planes:
            return evaluate(tree, x, y, z)
        return np.concatenate([np.broadcast_to(evaluate(tree, x[i:i + planes], y, z),
                                               (len(x[i:i + planes]), shape[1], shape[2]))
                               for i in range(0, len(x), planes)])
    return fn
