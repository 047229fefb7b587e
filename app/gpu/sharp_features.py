"""Extended Marching Cubes for the GPU extractor's meshes (`isoscope render --sharp` draws one: viewer/headless.py).

First pass 0 (`SharpExtractor.may_bend`, shaders/emc_flags.comp) asks the GPU whether any cell
may bend past the feature angle; where none may, the plain mesh is the answer and nothing is read
back (the viewer draws the extractor's own buffers).  Else the feature step
(isoscope.core.sharp.features.sharpen) runs on the mesh the Extractor read back, with
its per-patch solve (ENO normals, the planes' point) on the GPU: `SharpExtractor.patch_points`,
shaders/emc_solve.comp, which gives the numpy reference's points to ~1e-14.  Grouping triangles
into patches, the one-ring lists, fans, edge flips, the feature vertices' normals and the crisp
normals for drawing are still numpy (see isoscope.gpu.sharp).  For drawing, triangles at
feature vertices get face normals (core.sharp.normals.crisp_normals), so edges render crisp.
"""
from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import wait as wait_for

from ..core.sharp.features import Stopped, sharpen, signed_field
from ..core.sharp.normals import crisp_normals
from ..errors import InputError
from .mesh import GpuMesh, OwnedMesh
from .sharp import SharpExtractor


def sharp_mesh_of(extractor, volume_data, angle, field=None, gpu: SharpExtractor | None = None):
    """The extractor's last mesh with sharp features: verts, faces, normals, values, n_plain_vertices.

    `field`: signed_field(volume_data, extractor.descent) if already made; `gpu`: a SharpExtractor of
    `extractor`'s resident volume to reuse (else one is made and released here)."""
    solver = SharpExtractor(extractor.resident) if gpu is None else gpu
    try:
        sharpened = _sharpened(extractor, volume_data, angle, field, solver)
    finally:
        if gpu is None:
            solver.release()
    if sharpened is None:
        mesh = extractor.read_mesh()
        return (*mesh, len(mesh[0]))
    return sharpened


def _sharpened(extractor, volume_data, angle, field, gpu: SharpExtractor):
    """sharpen's result for the extractor's last mesh, or None where it is the plain mesh as it is, which
    pass 0 (SharpExtractor.may_bend) tells without reading the mesh back."""
    if gpu.may_bend(angle, extractor.mesh) is False:  # None: too large for the GPU's pass 0; sharpen tells
        return None
    field = signed_field(volume_data, extractor.descent) if field is None else field
    return sharpen(extractor.read_mesh(), field, extractor.spacing, angle, solver=gpu.patch_points)


def marching_cubes_sharp_gpu(checked, level, spacing, gradient_direction, angle):
    """`api.marching_cubes(..., sharp_features=angle, backend="gpu")`: extract, then sharp_mesh_of."""
    from .cubes import Extractor
    with Extractor(checked, spacing=spacing, gradient_direction=gradient_direction) as extractor:
        extractor.extract(level)
        return sharp_mesh_of(extractor, checked.data, angle)[:4]


def step_result(future):
    """A finished feature step's result; a failure on the worker (a bug, memory) as one ValueError line, the
    plain mesh staying on show (the GPU surface's and the CPU surface's polls)."""
    try:
        return future.result()
    except Exception as exc:
        raise InputError(f"sharp features failed ({type(exc).__name__}: {exc}); the plain mesh is shown") from None


class SharpenedMesh:
    """An extractor's last mesh with sharp features, uploaded for drawing with crisp normals (the
    viewer's GpuSurface shows it in place of the extractor's).  Offers what the viewer reads of an
    extractor: `mesh`, `level`, counts, `last_extract_ms`, `read_mesh()` (the mesh without the
    crisp-normal copies of vertices, as the API returns it).  A level without features draws the
    extractor's own buffers (no upload).

    `take(..., wait=False)` (the viewer's slider coming to rest) runs the numpy feature step on a
    worker thread, with the numpy patch solve (the GPU's gives the same points to ~1e-14), and shows
    the plain mesh meanwhile: on a scan the step takes about a second, and the window stays live.
    `poll()` swaps the result in when it is ready; a newer `take` (or `drop_pending`) stops an older
    step at its next check and drops its result unseen; `read_mesh()` waits for a pending one.  A step
    that fails leaves the plain mesh and raises ValueError from `poll` or `read_mesh`, once."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.mesh: GpuMesh | None = None  # on show: the extractor's (a view) or `_uploaded`
        self._uploaded: OwnedMesh | None = None  # the sharp mesh with crisp normals, this object's to release
        self.level = None
        self.n_vertices = self.n_triangles = 0
        self.last_extract_ms = 0.0
        self._arrays = None
        self._field, self._field_key = None, None
        self._gpu: SharpExtractor | None = None
        self._worker: ThreadPoolExecutor | None = None
        self._pending = None  # (future, stop event, the extractor, when it started) of a step on the worker
        self._generation = 0

    @property
    def pending(self) -> bool:
        """A feature step is running on the worker; the plain mesh is on show until it is in."""
        return self._pending is not None

    def take(self, extractor, volume_data, angle: float, wait: bool = True) -> None:
        start = time.perf_counter()
        self.drop_pending()
        # The signed float32 field, made once per volume and side (a volume's copy: not per extraction).
        key = (id(volume_data), extractor.descent)
        if self._field_key != key:
            self._field, self._field_key = signed_field(volume_data, extractor.descent), key
        if self._gpu is None or self._gpu.volume is not extractor.resident:
            self._release_gpu()
            self._gpu = SharpExtractor(extractor.resident)
        if wait:
            self._show(extractor, _sharpened(extractor, volume_data, angle, self._field, self._gpu), start)
            return
        if self._gpu.may_bend(angle, extractor.mesh) is False:  # pass 0: no cell can bend: the plain mesh
            self._show(extractor, None, start)
            return
        plain = extractor.read_mesh()
        self._show(extractor, None, start, plain)  # the plain mesh until the step is done
        if self._worker is None:
            self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="isoscope sharp features")
        self._generation += 1
        stop = threading.Event()
        future = self._worker.submit(_step, self._generation, plain, self._field, extractor.spacing, angle, stop)
        self._pending = (future, stop, extractor, start)

    def poll(self) -> bool:
        """Show a finished feature step's mesh; True when the mesh on show changed.  ValueError: the
        step failed (the plain mesh stays on show)."""
        if self._pending is None or not self._pending[0].done():
            return False
        future, _, extractor, start = self._pending
        self._pending = None
        generation, sharpened = step_result(future)
        if generation != self._generation or sharpened is _STOPPED:
            return False
        self._show(extractor, sharpened, start)
        return True

    def _show(self, extractor, sharpened, start: float, plain_arrays=None) -> None:
        # No feature at this level: the extractor's mesh as it is (without a read-back where pass 0 says so).
        plain = sharpened is None or len(sharpened[0]) == sharpened[4]
        uploaded = None if plain else GpuMesh.upload(self.ctx, *crisp_normals(*sharpened))
        self._release_mesh()
        self._uploaded = uploaded
        self.mesh = extractor.mesh if plain else uploaded
        self._arrays = plain_arrays if sharpened is None else sharpened[:4]
        self.level = extractor.level
        self.n_vertices, self.n_triangles = ((extractor.n_vertices, extractor.n_triangles) if sharpened is None
                                             else (len(sharpened[0]), len(sharpened[1])))
        self.last_extract_ms = extractor.last_extract_ms + 1000 * (time.perf_counter() - start)

    def read_mesh(self):
        if self._pending is not None:  # the sharp mesh is on its way: wait for it
            wait_for([self._pending[0]])
            self.poll()
        if self._arrays is None and self.mesh is not None:  # the extractor's plain mesh, read when asked
            self._arrays = self.mesh.read()
        return self._arrays

    def release(self) -> None:
        self.drop_pending()
        if self._worker is not None:
            self._worker.shutdown(wait=False, cancel_futures=True)
            self._worker = None
        self._field, self._field_key = None, None
        self._release_gpu()
        self._release_mesh()

    def drop_pending(self) -> None:
        """Forget a step on the worker: it never starts, or stops at its next check, unseen."""
        if self._pending is not None:
            self._pending[0].cancel()
            self._pending[1].set()
            self._pending = None
        self._generation += 1

    def _release_gpu(self) -> None:
        if self._gpu is not None:
            self._gpu.release()
            self._gpu = None

    def _release_mesh(self) -> None:
        if self._uploaded is not None:
            self._uploaded.release()
        self.mesh = self._uploaded = None


_STOPPED = object()


def _step(generation, plain, field, spacing, angle, stop):
    """The numpy feature step (the worker's): (generation, sharpen's result, or _STOPPED)."""
    try:
        return generation, sharpen(plain, field, spacing, angle, stop=stop)
    except Stopped:
        return generation, _STOPPED
