"""The viewer's GL side of one volume: its extractors, in the window's context, and the mesh on show.

While the iso value moves, a mesh with hundreds of thousands of triangles costs
llvmpipe 100+ ms a frame to draw: its vertex work is single-threaded (130-250 ms
per million triangles, measured on a brain MRI; the window's size hardly matters).
So, as ParaView does while interacting, a moving value is extracted from a coarser
copy of the volume (every `step`-th sample along each axis, resident beside the full
one), and the full mesh comes back once the value rests.  The scene chooses the step
(scene.py: from measured frame times, model/pacing.py; before any, the step whose mesh
stays under `PREVIEW_TRIANGLES`) and when the full mesh comes back.  What each extraction makes (cells,
smoothing, sharp features) is the `MeshOptions` it is given: the surface keeps no setting
of its own, only what is on show.
"""
from __future__ import annotations

from ...gpu.cubes import Extractor
from ...gpu.limits import GPULimitError, GpuLimits, plan_extractor
from ...gpu.mesh import GpuMesh
from ...gpu.sharp_features import SharpenedMesh
from ...gpu.smooth import Smoother
from ...gpu.tetra import TetraExtractor
from ...options import MeshOptions
from ...validation import subsampled
from ...volumes import Volume

PREVIEW_TRIANGLES = 60_000
"""Triangles a preview mesh aims to stay under: llvmpipe draws about that many in 10-15 ms."""

MAX_PREVIEW_STEP = 8
"""The coarsest preview: every 8th sample.  A 512x512x400 CT's full mesh at bone (1.2-2.4 M triangles) needs a
step of 5-7 to stay near PREVIEW_TRIANGLES; at 4 (the old cap) its drag frames took 64 ms median, 183 at the
90th percentile on llvmpipe (benchmarks/bench_viewer.py), now 31 and 42."""


def coarsest_step(shape) -> int:
    """The coarsest preview step of a volume of `shape`: MAX_PREVIEW_STEP, less where an axis would keep
    fewer than two samples (1: too thin to subsample)."""
    return max(1, min(MAX_PREVIEW_STEP, min(shape) - 1))


def preview_step(full_triangles: int, shape, budget: int | None = None) -> int:
    """The sample step whose mesh should stay under `budget` (default PREVIEW_TRIANGLES): a
    surface's triangle count falls with the square of the step.  1 when the full mesh is already
    small enough, or the volume too thin to subsample.  The first guess of a drag, before its frames
    are measured (model/pacing.py)."""
    budget = PREVIEW_TRIANGLES if budget is None else budget
    step = 1
    while full_triangles > budget * step * step and step < MAX_PREVIEW_STEP:
        step += 1
    return min(step, coarsest_step(shape))


def extractor_refusal(ctx):
    """A function saying why a GpuSurface in `ctx` cannot hold a volume of a given shape (the extractor's GL
    limits, gpu/limits.py: llvmpipe's 128 MiB storage blocks stop a 1024^3 volume), or None where it can."""
    limits = GpuLimits.of(ctx)

    def refusal(shape) -> str | None:
        """Why the GPU extractor cannot hold a volume of `shape` (the first clause of its GPULimitError), or None."""
        try:
            plan_extractor(shape, limits)
        except GPULimitError as exc:
            return str(exc).split(";")[0]
        return None
    return refusal


class GpuSurface:
    """Owns the extractors of one volume: the full-resolution one and coarser previews."""

    def __init__(self, ctx, volume: Volume, gradient_direction: str):
        self.ctx = ctx
        self.volume = volume
        self.gradient_direction = gradient_direction
        self.extractor = Extractor(volume.checked, spacing=volume.spacing,
                                   gradient_direction=gradient_direction, ctx=ctx)
        self._previews: dict[int, Extractor] = {}  # sample step -> extractor of the subsampled volume
        self.shown_step = 1  # the step of the mesh on show: 1 is full resolution
        self.made_preview = False  # the last extraction made its step's extractor (an upload: a slow frame)
        # The cells of the mesh on show.  Tetrahedra borrow the cubes extractor's resident volume of
        # the same step (gpu/tetra.py): no re-upload.
        self.shown_cells = "cubes"
        self._tetrahedra: dict[int, TetraExtractor] = {}  # sample step -> its tetrahedra extractor
        # The full mesh's triangle count, estimated from the last mesh of any step (a surface's
        # count grows with the square of the resolution): sizes the next preview's step.
        self.full_triangles = 0
        self._smoothers: dict[tuple[str, int], Smoother] = {}  # (cells, sample step) -> its extractor's smoother
        # The feature step of Extended MC runs in numpy on the read-back mesh, so only full-resolution
        # cubes meshes get it: previews while dragging stay plain.
        self._sharpened = SharpenedMesh(ctx)
        self.shown_sharp = False

    @property
    def value_range(self) -> tuple[float, float]:
        """The volume's smallest and largest values."""
        return self.extractor.value_range

    @property
    def shown(self) -> Extractor:
        """The extractor whose mesh is on show (or the sharp-featured mesh standing in for it)."""
        if self.shown_sharp:
            return self._sharpened
        if self.shown_cells == "tetrahedra":
            return self._tetrahedra[self.shown_step]
        return self.extractor if self.shown_step == 1 else self._previews[self.shown_step]

    @property
    def mesh(self) -> GpuMesh:
        """The mesh on show as the renderer draws it."""
        return self.shown.mesh

    @staticmethod
    def makes(options: MeshOptions) -> bool:
        """Whether this surface makes meshes with these options.  The trilinear topology's meshes are drawn
        from a `CpuSurface` (the compiled extractor, the same mesh): its GPU passes (`isoscope.gpu.trilinear`)
        serve the API, but hold a mesh in one storage block and are not yet composed with this surface's
        previews, smoothing and sharp features."""
        return options.topology == "montani"

    def extract(self, iso: float, options: MeshOptions, step: int = 1, wait: bool = True) -> None:
        """Extract at `iso` as `options` say: the full mesh, or with `step` > 1 a preview from every
        step-th sample (its extractor made and kept the first time: `made_preview`).  Without `wait`,
        sharp features are made on a worker thread (the plain mesh shows until `poll` brings them in)."""
        step = min(int(step), coarsest_step(self.volume.data.shape))
        self.made_preview = step > 1 and step not in self._previews
        if self.made_preview:
            self._previews[step] = self._make_preview(step)
        extractor = self.extractor if step == 1 else self._previews[step]
        if options.cells == "tetrahedra":
            if step not in self._tetrahedra:
                self._tetrahedra[step] = TetraExtractor(extractor)
            extractor = self._tetrahedra[step]
        try:
            extractor.extract(iso)
        except BaseException:  # the sharp mesh on show (or on its way) belongs to what the extractor had
            self._sharpened.drop_pending()
            self.shown_sharp = False
            raise
        if options.smooth:
            key = (options.cells, step)
            if key not in self._smoothers:
                self._smoothers[key] = Smoother(extractor)
            self._smoothers[key].smooth(extractor.mesh, options.smooth)
        self.shown_sharp = options.sharp is not None and step == 1 and options.cells == "cubes"
        if self.shown_sharp:
            self._sharpened.take(extractor, self.volume.checked.data, options.sharp, wait=wait)
        else:  # a preview or another mode: a step still on the worker is not wanted
            self._sharpened.drop_pending()
        self.shown_step, self.shown_cells = step, options.cells
        self.full_triangles = extractor.n_triangles * step * step

    @property
    def sharp_pending(self) -> bool:
        """Sharp features are being made on the worker; the plain mesh is on show meanwhile."""
        return self.shown_sharp and self._sharpened.pending

    def poll(self) -> bool:
        """Bring in sharp features made on the worker; True when the mesh on show changed."""
        return self.shown_sharp and self._sharpened.poll()

    def settle(self) -> None:
        """Wait for sharp features being made on the worker, and show them."""
        if self.sharp_pending:
            self._sharpened.read_mesh()

    def _make_preview(self, step: int) -> Extractor:
        return Extractor(subsampled(self.volume.checked, step), spacing=tuple(s * step for s in self.volume.spacing),
                         gradient_direction=self.gradient_direction, ctx=self.ctx)

    def release(self) -> None:
        """Free the extractors (the smoothers' and tetrahedra's first: they borrow the volume) and their meshes."""
        # Smoothers and tetrahedra borrow their extractor's volume: released first.
        for gl_owner in (self._sharpened, *self._smoothers.values(), *self._tetrahedra.values(), self.extractor,
                         *self._previews.values()):
            gl_owner.release()
        self._previews.clear()
        self._tetrahedra.clear()
        self._smoothers.clear()
