"""An extractor's work space: what its passes write and read between them, of fixed size for its volume.

Per word (2-D images, ExtractorPlan.word_image_size): the sign words, the counts (the cell kind's
`count_components`) and the offsets; per brick (storage buffers): the vertex and triangle counts that
the scan turns into offsets, the active list and the brick states; the indirect dispatch sizes, the
case table's image, the scan's own scratch, and for a mesh larger than a storage block the per-run
brick list, made when first needed.  `ExtractionScratch` owns them all and releases them together.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ..core.case_table import CaseTable
from ..core.layout import ImageUnit, StorageBlock
from .cell_kind import CASE_TABLE_SHIFT
from .limits import ExtractorPlan
from .scan import ExclusiveScan


def case_table_image(ctx: moderngl.Context, table: CaseTable) -> moderngl.Texture:
    """`table`'s words (CaseTable.packed_for_gpu) in an r32ui image 2^CASE_TABLE_SHIFT texels wide."""
    words = table.packed_for_gpu()
    width = 1 << CASE_TABLE_SHIFT
    words = np.concatenate([words, np.zeros(-len(words) % width, np.uint32)])
    return ctx.texture((width, len(words) // width), 1, words.tobytes(), dtype="u4")


class ExtractionScratch:
    """The work images and buffers of one extractor, sized by `plan`; all or nothing (a failed
    allocation releases what was made and raises)."""

    def __init__(self, ctx: moderngl.Context, plan: ExtractorPlan, count_components: int, table: CaseTable,
                 offset_components: int = 2, own_vertices: bool = False):
        self.ctx, self.plan = ctx, plan
        self._owned: list = []  # every fixed-size GL object allocated here, released together
        self.scan: ExclusiveScan | None = None
        self.run_list: moderngl.Buffer | None = None  # a large mesh's per-run brick list, made when needed
        self.brick_own_offsets: moderngl.Buffer | None = None  # cells' own vertices per brick (own_vertices)
        self.edge_vertices = self.own_vertices = 0  # the last scan's totals of each
        try:
            self.sign_words = self._own(ctx.texture(plan.word_image_size, 1, dtype="u4"))
            self.word_counts = self._own(ctx.texture(plan.word_image_size, count_components, dtype="u4"))
            # (first vertex, triangle[, own vertex])
            self.word_offsets = self._own(ctx.texture(plan.word_image_size, offset_components, dtype="u4"))
            sizes = plan.storage_elements()
            self.brick_vertex_offsets = self._storage(sizes["brick vertex offsets"])
            self.brick_triangle_offsets = self._storage(sizes["brick triangle offsets"])
            if own_vertices:
                self.brick_own_offsets = self._storage(sizes["brick vertex offsets"])
            self.active_bricks = self._storage(sizes["active bricks"])
            self.brick_states = self._storage(sizes["brick states"])  # of its own sign words
            self.brick_states.clear()  # 0: the sign words hold nothing known (mc_bricks.comp)
            self.dispatch_args = self._own(ctx.buffer(reserve=24))  # groups per active brick, then per 64 bricks
            self.case_table = self._own(case_table_image(ctx, table))
            self.scan = ExclusiveScan(ctx)
        except BaseException:
            self.release()
            raise

    def _own(self, gl_object):
        self._owned.append(gl_object)
        return gl_object

    def _storage(self, elements: int) -> moderngl.Buffer:
        """A work buffer; plan_extractor has already checked its size against the limit."""
        return self._own(self.ctx.buffer(reserve=max(elements, 1) * 4))

    @property
    def allocated(self) -> bool:
        return bool(self._owned)

    # -- what the passes bind -------------------------------------------------------------------

    def bind_images(self) -> None:
        """The per-word images and the case table at their units (the volume is the resident's)."""
        self.sign_words.bind_to_image(ImageUnit.SIGN_WORDS, read=True, write=True)
        self.word_counts.bind_to_image(ImageUnit.WORD_COUNTS, read=True, write=True)
        self.word_offsets.bind_to_image(ImageUnit.WORD_OFFSETS, read=True, write=True)
        self.case_table.bind_to_image(ImageUnit.CASE_TABLE, read=True, write=False)  # see mc_case_table.glsl

    def bind_brick_offsets(self) -> None:
        """The per-brick vertex and triangle counts (offsets once scanned) at their blocks."""
        self.brick_vertex_offsets.bind_to_storage_buffer(StorageBlock.BRICK_VERTICES)
        self.brick_triangle_offsets.bind_to_storage_buffer(StorageBlock.BRICK_TRIANGLES)
        if self.brick_own_offsets is not None:
            self.brick_own_offsets.bind_to_storage_buffer(StorageBlock.BRICK_OWN_VERTICES)

    def bind_counting(self, brick_ranges: moderngl.Buffer) -> None:
        """Every block passes 1-4 use, `brick_ranges` (the resident volume's) among them."""
        self.bind_brick_offsets()
        for binding, buffer in ((StorageBlock.ACTIVE_BRICKS, self.active_bricks),
                                (StorageBlock.BRICK_RANGES, brick_ranges),
                                (StorageBlock.DISPATCH_ARGS, self.dispatch_args),
                                (StorageBlock.BRICK_STATES, self.brick_states)):
            buffer.bind_to_storage_buffer(binding)

    def bind_run_list(self, bricks: np.ndarray) -> None:
        """`bricks` as a list in the active list's place (mc_active_bricks.glsl), for one run's dispatch."""
        if self.run_list is None:
            self.run_list = self._own(self.ctx.buffer(reserve=4 * (self.plan.brick_count + 1)))
        self.run_list.write(np.concatenate([[len(bricks)], bricks]).astype(np.uint32))
        self.run_list.bind_to_storage_buffer(StorageBlock.ACTIVE_BRICKS)

    # -- what is read back ----------------------------------------------------------------------

    def clear_active_count(self) -> None:
        self.active_bricks.write(b"\0\0\0\0")  # the active count, appended to by mc_bricks
        if self.brick_own_offsets is not None:
            self.brick_own_offsets.clear()  # pass 4 counts only the active bricks' own vertices

    def active_count(self) -> int:
        return int(np.frombuffer(self.active_bricks.read(4), np.uint32)[0])

    def scan_brick_counts(self) -> tuple[int, int]:
        """Pass 5: the per-brick counts become offsets; returns the totals (vertices, triangles), the
        cells' own vertices among the vertices (kept apart in edge_vertices, own_vertices)."""
        count = self.plan.brick_count + 1
        total_at = self.plan.brick_count * 4
        totals = []
        for buffer in (self.brick_vertex_offsets, self.brick_triangle_offsets, self.brick_own_offsets):
            if buffer is not None:
                self.scan(buffer, count)
                totals.append(int(np.frombuffer(buffer.read(4, total_at), np.uint32)[0]))
        self.edge_vertices, n_triangles, self.own_vertices = (*totals, 0)[:3]
        return self.edge_vertices + self.own_vertices, n_triangles

    def brick_offsets(self) -> tuple[np.ndarray, np.ndarray]:
        """Each brick's first triangle and first vertex (int64, the totals last), once scanned."""
        count = self.plan.brick_count + 1
        firsts = np.frombuffer(self.brick_triangle_offsets.read(4 * count), np.uint32).astype(np.int64)
        vertices = np.frombuffer(self.brick_vertex_offsets.read(4 * count), np.uint32).astype(np.int64)
        return firsts, vertices

    def nbytes(self) -> int:
        """GPU memory of the images, the work buffers and the scan's scratch."""
        if not self._owned:
            return 0
        images = (self.sign_words, self.word_counts, self.word_offsets, self.case_table)
        buffers = (self.brick_vertex_offsets, self.brick_triangle_offsets, self.active_bricks, self.brick_states,
                   self.dispatch_args, *([self.brick_own_offsets] if self.brick_own_offsets else []))
        return (sum(t.width * t.height * t.components * 4 for t in images) + sum(b.size for b in buffers)
                + self.scan.scratch_bytes())

    def release(self) -> None:
        """Free every GL object made here; safe to call twice, or on a half-built one."""
        for obj in self._owned:
            obj.release()
        self._owned.clear()
        self.run_list = self.brick_own_offsets = None
        if self.scan is not None:
            self.scan.release()
