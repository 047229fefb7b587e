"""One `Extractor` kept between one-shot calls (`isoscope.marching_cubes`, `marching_tetrahedra`).

A one-shot call used to make an Extractor and release it: every call allocated the volume image,
the per-word images and the mesh buffers afresh.  New storage is not free: llvmpipe zeroes it and
the OS maps it a page at a time (on a 256^3 float32 sphere, 26 ms of a ~90 ms call went to the
volume image's allocation alone, and the mesh buffers grew from nothing again each call).  As
CuPy's and PyTorch's allocators keep GPU memory for the next call, the last call's extractor is
kept here; a call with a volume of the same shape and sample type writes its samples into it
(`Extractor.reload`) instead.  The price is that memory (at most KEEP_LIMIT_BYTES of it) stays
allocated after the call returns: `release_gpu_memory()` gives it back.

Only the standalone context's extractor is kept (a viewer's window context is its own), and one
call at a time uses it: a call made while another holds it (another thread) gets a fresh one.
"""
from __future__ import annotations

import threading
from contextlib import contextmanager

KEEP_LIMIT_BYTES = 1 << 30
"""An extractor holding more GL memory than this (volume image, scratch and mesh buffers) is released."""

_lock = threading.Lock()
_kept = None  # the Extractor kept since the last call, or None
_reused = 0  # calls that reused it (tests read this through `stats`)


@contextmanager
def pooled_extractor(checked, spacing, gradient_direction):
    """An Extractor holding `checked` (a validation.CheckedVolume), the kept one where it fits."""
    from . import context as gl_context
    from .cubes import Extractor
    global _kept, _reused
    ctx = gl_context.current_or_standalone()
    if ctx is not gl_context._standalone or not _lock.acquire(blocking=False):
        with Extractor(checked, spacing=spacing, gradient_direction=gradient_direction, ctx=ctx) as extractor:
            yield extractor
        return
    try:
        extractor, _kept = _kept, None
        if extractor is not None and (extractor.ctx is not ctx or not extractor.fits(checked)):
            extractor.release()  # before the new one is allocated: one volume's memory at a time
            extractor = None
        if extractor is None:
            extractor = Extractor(checked, spacing=spacing, gradient_direction=gradient_direction, ctx=ctx)
        else:
            try:
                extractor.reload(checked, spacing, gradient_direction)
            except BaseException:
                extractor.release()
                raise
            _reused += 1
        try:
            yield extractor
        except BaseException:
            extractor.release()  # its state is whatever the failure left: start afresh next time
            raise
        if extractor.gpu_bytes() <= KEEP_LIMIT_BYTES:
            _kept = extractor
        else:
            extractor.release()
    finally:
        _lock.release()


def release_gpu_memory() -> int:
    """Release the extractor that one-shot calls keep on the GPU for the next call.

    isoscope.marching_cubes (and marching_tetrahedra, label_surfaces) on the GPU keep their last
    extractor, so a second call on a volume of the same shape reuses its buffers instead of
    allocating them again.  Call this to give that memory back.

    Returns
    -------
    int
        The bytes of GPU memory it held (0 when none was kept).

    Examples
    --------
    >>> import numpy as np
    >>> import isoscope
    >>> ball = np.fromfunction(lambda i, j, k: (i - 8.0) ** 2 + (j - 8.0) ** 2 + (k - 8.0) ** 2, (17, 17, 17))
    >>> _ = isoscope.marching_cubes(ball, 25.0, backend="gpu")
    >>> isoscope.release_gpu_memory() > 0
    True
    >>> isoscope.release_gpu_memory()
    0
    """
    global _kept
    with _lock:
        extractor, _kept = _kept, None
        if extractor is None:
            return 0
        held = extractor.gpu_bytes()
        extractor.release()
        return held


def stats() -> dict:
    """What is kept: {"kept_bytes": ..., "reused_calls": ...}."""
    with _lock:
        return {"kept_bytes": 0 if _kept is None else _kept.gpu_bytes(), "reused_calls": _reused}
