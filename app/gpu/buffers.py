"""One GL buffer that grows with what it is asked to hold, for the work and mesh buffers that do.

A mesh, the smoothing's per-vertex list or a feature step's patch lists change size with the level;
reallocating on every change costs llvmpipe a zeroing pass and the OS a page fault per page.  So a
buffer too small for a request is replaced by one half as large again (or as large as asked, when
that is more), and a smaller request keeps it: dragging the slider rarely reallocates.
"""
from __future__ import annotations

import moderngl

GROWTH = 1.5
"""A buffer that must grow takes this many times its old size (or the size asked, when larger)."""


class GrowableBuffer:
    """A GL buffer of at least the bytes last asked for (`ensure`, `write`); its owner releases it.

    `buffer` is None only after `release`, or where a failed allocation could not even leave
    `minimum` bytes behind."""

    def __init__(self, ctx: moderngl.Context, minimum: int = 4):
        self.ctx, self.minimum = ctx, minimum
        self.buffer: moderngl.Buffer | None = ctx.buffer(reserve=minimum)

    @property
    def size(self) -> int:
        """Bytes held (0 when there is no buffer)."""
        return 0 if self.buffer is None else self.buffer.size

    def ensure(self, needed: int) -> moderngl.Buffer:
        """The buffer, grown to hold `needed` bytes if it does not (its contents are then lost).  A failed
        allocation raises moderngl.Error and leaves a `minimum`-byte buffer where one can be had."""
        if self.size < needed:
            size = max(needed, int(self.size * GROWTH))
            self.release()
            try:
                self.buffer = self.ctx.buffer(reserve=size)
            except moderngl.Error:
                try:
                    self.buffer = self.ctx.buffer(reserve=self.minimum)
                except moderngl.Error:
                    pass
                raise
        return self.buffer

    def write(self, data: bytes) -> moderngl.Buffer:
        """The buffer holding `data` at its start (grown to fit)."""
        buffer = self.ensure(max(len(data), self.minimum))
        if data:
            buffer.write(data)
        return buffer

    def release(self) -> None:
        if self.buffer is not None:
            self.buffer.release()
            self.buffer = None


class GrowableBuffers:
    """Growable buffers of one owner by name (or any key: the scan's level), released together (a pass's
    scratch)."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self._buffers: dict[object, GrowableBuffer] = {}

    def __getitem__(self, name) -> GrowableBuffer:
        if name not in self._buffers:
            self._buffers[name] = GrowableBuffer(self.ctx)
        return self._buffers[name]

    def nbytes(self) -> int:
        return sum(buffer.size for buffer in self._buffers.values())

    def release(self) -> None:
        for buffer in self._buffers.values():
            buffer.release()
        self._buffers.clear()
