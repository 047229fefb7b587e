"""Exclusive prefix sum of a uint32 GPU buffer, in place, any length (multi-level)."""
from __future__ import annotations

import moderngl

from ..core.layout import SCAN_BLOCK, StorageBlock
from .buffers import GrowableBuffers
from .programs import compute_program, dispatch_groups, set_uniforms


class ExclusiveScan:
    """Scans uint32 buffers of any length in place; keeps one scratch buffer of block sums per level."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self._reduce = compute_program(ctx, "scan_reduce.comp")
        self._apply = compute_program(ctx, "scan_apply.comp")
        self._scratch = GrowableBuffers(ctx)  # level -> block sums

    def _sums_buffer(self, level: int, blocks: int) -> moderngl.Buffer:
        return self._scratch[level].ensure(blocks * 4)

    def __call__(self, data: moderngl.Buffer, count: int, level: int = 0) -> None:
        """data[i] <- sum(data[:i]) for i < count."""
        blocks = -(-count // SCAN_BLOCK)
        if blocks <= 1:
            data.bind_to_storage_buffer(StorageBlock.SCAN_DATA)
            set_uniforms(self._apply, u_count=count, u_blocks=1, u_has_offsets=False)
            dispatch_groups(self._apply, 1)
            self.ctx.memory_barrier()
            return
        sums = self._sums_buffer(level, blocks)
        data.bind_to_storage_buffer(StorageBlock.SCAN_DATA)
        sums.bind_to_storage_buffer(StorageBlock.SCAN_SUMS)
        set_uniforms(self._reduce, u_count=count, u_blocks=blocks)
        dispatch_groups(self._reduce, blocks)
        self.ctx.memory_barrier()

        self(sums, blocks, level + 1)

        data.bind_to_storage_buffer(StorageBlock.SCAN_DATA)
        sums.bind_to_storage_buffer(StorageBlock.SCAN_SUMS)
        set_uniforms(self._apply, u_count=count, u_blocks=blocks, u_has_offsets=True)
        dispatch_groups(self._apply, blocks)
        self.ctx.memory_barrier()

    def scratch_bytes(self) -> int:
        return self._scratch.nbytes()

    def release(self) -> None:
        self._scratch.release()
