"""`expr:FORMULA[; box=...][; res=N]` specs: parse the spec, sample the formula, check the result.

The object is where the formula is negative (an implicit surface F = 0 with
F < 0 inside, the usual convention for implicit surfaces and level sets), so the gradient direction is "ascent" and
the first level is 0.
"""
from __future__ import annotations

import numpy as np

from .errors import VolumeError
from .expression import evaluate, parse
from .grid import Box, pick_resolution, sample_function
from .volume import Progress, Volume, finish_volume

PREFIX = "expr:"
DEFAULT_BOX = Box.cube(-1.0, 1.0)
DEFAULT_RESOLUTION = 64
_OPTIONS_HELP = "use box=LO,HI or box=X0,X1,Y0,Y1,Z0,Z1 and res=N"


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
    return Box(tuple(values[0::2]), tuple(values[1::2]))


def open_expression(spec: str, *, resolution=None, progress: Progress | None = None,
                    backend: str = "auto", ctx=None) -> Volume:
    formula, box, spec_resolution = split_expression_spec(spec)
    tree = parse(formula)  # before any GL work: a typo costs nothing
    n = pick_resolution(spec_resolution, resolution, DEFAULT_RESOLUTION, "expr")
    shape = (n, n, n)
    data, notes = _sample(tree, box, shape, backend, ctx, progress)
    spacing = box.spacing(shape)

    def where(index) -> str:
        x, y, z = (box.lo[a] + index[a] * spacing[a] for a in range(3))
        return (f"at x={x:.4g}, y={y:.4g}, z={z:.4g} (e.g. log or sqrt of a negative number, "
                f"division by zero, overflow); change the formula or the box")

    name = formula if len(formula) <= 40 else formula[:37] + "..."
    return finish_volume(data, spacing=spacing, name=name, source=spec, gradient_direction="ascent",
                         default_level=0.0, notes=notes, what=f"expression {formula!r}",
                         progress=progress, where=where)


def _sample(tree, box: Box, shape, backend: str, ctx, progress):
    if backend not in ("auto", "gpu", "cpu"):
        raise ValueError(f"backend must be 'auto', 'gpu' or 'cpu', not {backend!r}")
    if backend != "cpu":
        from isoscope.gl_context import GLUnavailable
        try:
            from .gpu_sampler import sample_on_gpu
            return sample_on_gpu(tree, box, shape, ctx=ctx, progress=progress), []
        except GLUnavailable as exc:
            if backend == "gpu":
                raise VolumeError(f"cannot sample on the GPU: {exc}; use the cpu backend") from None
            note = "no GPU context; the expression was sampled with numpy"
        except VolumeError:
            raise
        except Exception as exc:  # a driver failure must not cost the user their volume
            if backend == "gpu":
                raise VolumeError(f"GPU sampling failed ({type(exc).__name__}: {exc}); "
                                  f"use the cpu backend") from None
            note = f"GPU sampling failed ({type(exc).__name__}); the expression was sampled with numpy"
    else:
        note = None
    data = sample_function(lambda x, y, z: evaluate(tree, x, y, z), box, shape,
                           what="the expression", progress=progress)
    return data, [note] if note else []
