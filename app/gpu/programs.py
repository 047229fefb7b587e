"""Compiled compute programs and timer queries, one set per GL context, and the dispatch helper they share."""
from __future__ import annotations

import weakref

import moderngl

from ..core.layout import MAX_GROUPS_PER_DIMENSION, shader_defines
from ..resources import shader_source

_cache: weakref.WeakKeyDictionary[moderngl.Context, dict] = weakref.WeakKeyDictionary()
_timers: weakref.WeakKeyDictionary[moderngl.Context, tuple] = weakref.WeakKeyDictionary()


def compute_program(ctx: moderngl.Context, name: str, defines: dict | None = None) -> moderngl.ComputeShader:
    """shaders/NAME compiled for ctx, cached: llvmpipe spends tens of ms compiling each one.

    Every program gets core/layout.py's #defines, then `defines` (the case table's sizes and the like).
    """
    programs = _cache.setdefault(ctx, {})
    key = (name, tuple(sorted((defines or {}).items())))
    if key not in programs:
        programs[key] = ctx.compute_shader(shader_source(name, {**shader_defines(), **(defines or {})}))
    return programs[key]


def timer_queries(ctx: moderngl.Context) -> tuple[moderngl.Query, moderngl.Query]:
    """Two GL_TIME_ELAPSED queries of ctx, shared by the extractors made in it.

    moderngl (5.x) has no way to delete a query: one pair per extractor outlived every `release()`
    (two GL objects leaked per extractor made), so the context keeps one pair, as it keeps the
    programs.  Extractions are synchronous, so no two extractors time with them at once."""
    if ctx not in _timers:
        _timers[ctx] = (ctx.query(time=True), ctx.query(time=True))
    return _timers[ctx]


def dispatch_groups(program: moderngl.ComputeShader, groups: int) -> None:
    """Run `groups` work groups, folded into 2-D when one dimension's limit would be passed.

    Shaders rebuild the linear group id as y * num_groups.x + x and bounds-check it.  The fold is
    as even as it can be (x * y - groups < y): empty groups are not free on llvmpipe, and folding
    65,536 groups as 65,535 x 2 once added ~65,000 of them, ~140 ms to a 4.2 M vertex pass.
    """
    if groups <= 0:
        return
    y = -(-groups // MAX_GROUPS_PER_DIMENSION)
    x = -(-groups // y)
    program.run(x, y, 1)


def set_uniforms(program: moderngl.ComputeShader, **values) -> None:
    """Set the uniforms the program uses; the GLSL compiler drops unused ones, so skip those."""
    for name, value in values.items():
        if name in program:
            program[name].value = value
