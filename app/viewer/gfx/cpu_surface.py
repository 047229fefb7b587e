"""The viewer's surface of one volume where the context has no compute shaders (OpenGL 4.1, macOS).

`CpuSurface` is `GpuSurface`'s twin (surface.py: the same `extract`, `shown`, `mesh`, `poll`, `settle`,
`release`), for a context below 4.3: meshes are extracted on the CPU (`isoscope.cpu.extractor.CpuExtractor`,
the volume kept resident, one per sample step as the GPU keeps its previews) and each new mesh is uploaded
into a vertex and an index buffer of the same record layout the GPU extractor writes, so the renderer,
the level copies and the labels draw it unchanged.  Tetrahedra are compiled too (the same kernels, six
tetrahedra per cell); smoothing and sharp features run their numpy steps on the extracted mesh.  Sharp
features, as on the GPU (gpu/sharp_features.py), are drawn with crisp normals and, without `wait` (the
window's slider coming to rest), made on a worker thread while the plain mesh shows; `poll` brings them
in, a newer extraction drops a step still running.
"""
from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ...core.layout import INDEX_BYTES, VERTEX_BYTES, VERTEX_FIELDS, VERTEX_FLOATS
from ...core.sharp.features import Stopped, sharpen, signed_field
from ...core.sharp.normals import crisp_normals
from ...cpu.available import cpu_extractor_class, tetrahedra_function, threads_for
from ...cpu.smooth import smooth_projected
from ...gpu.buffers import GrowableBuffer
from ...gpu.mesh import GpuMesh, empty_mesh
from ...gpu.sharp_features import step_result
from ...options import MeshOptions
from ...validation import as_gradient_direction, as_level, subsampled
from ...volumes import Volume
from .surface import coarsest_step


def vertex_records(verts, normals, values) -> bytes:
    """The GPU extractor's vertex records (core/layout.VERTEX_FIELDS) of numpy arrays."""
    records = np.zeros((len(verts), VERTEX_FLOATS), np.float32)
    start = 0
    for name, width in VERTEX_FIELDS:
        column = {"position": verts, "value": values, "normal": normals}.get(name)
        if column is not None:
            records[:, start:start + width] = np.reshape(column, (-1, width))
        start += width
    return records.tobytes()


class CpuMesh:
    """One CPU extraction's mesh, its arrays kept and uploaded: what `GpuSurface.shown` gives the scene
    (`mesh`, `n_vertices`, `n_triangles`, `last_extract_ms`, `level`, `read_mesh`)."""

    def __init__(self, ctx):
        self.ctx = ctx
        self._vertices = GrowableBuffer(ctx, VERTEX_BYTES)
        self._indices = GrowableBuffer(ctx, INDEX_BYTES)
        self._arrays = empty_mesh()
        self.n_vertices = self.n_triangles = 0
        self.level: float | None = None
        self.last_extract_ms = 0.0

    def take(self, arrays, level: float, extract_ms: float, drawn=None) -> None:
        """Show `arrays` (verts, faces, normals, values), drawing `drawn` instead where given (a sharp
        mesh's crisp-normal copy); `read_mesh` gives `arrays`."""
        verts, faces, normals, values = arrays if drawn is None else drawn
        self._vertices.write(vertex_records(verts, normals, values))
        self._indices.write(np.ascontiguousarray(faces, np.uint32).tobytes())
        self._arrays = arrays
        self.n_vertices, self.n_triangles = len(verts), len(faces)
        self.level, self.last_extract_ms = level, extract_ms

    @property
    def mesh(self) -> GpuMesh:
        """The uploaded mesh as the renderer draws it."""
        return GpuMesh(self._vertices.buffer, self._indices.buffer, self.n_vertices, self.n_triangles)

    def read_mesh(self):
        """verts, faces, normals, values of the mesh on show (copies)."""
        return tuple(np.array(part, copy=True) for part in self._arrays)

    def release(self) -> None:
        """Free the mesh's vertex and index buffers."""
        self._vertices.release()
        self._indices.release()


class CpuSurface:
    """`GpuSurface` for a context with no compute shaders: meshes made on the CPU, drawn from a VBO."""

    def __init__(self, ctx, volume: Volume, gradient_direction: str):
        self.ctx = ctx
        self.volume = volume
        self.gradient_direction = gradient_direction
        self._descent = as_gradient_direction(gradient_direction)
        make = cpu_extractor_class()
        self._make = make
        self.extractor = make(volume.checked, spacing=volume.spacing, gradient_direction=gradient_direction)
        self._previews: dict[int, object] = {}   # sample step -> extractor of the subsampled volume
        self._trilinear: dict[int, object] = {}  # sample step -> its extractor of the trilinear topology
        self._shown = CpuMesh(ctx)
        self.shown_step = 1
        self.made_preview = False
        self.shown_cells = "cubes"
        self.shown_sharp = False
        self.full_triangles = 0
        self._field, self._field_key = None, None   # the signed field sharp features need, once per volume
        self._worker: ThreadPoolExecutor | None = None
        self._pending = None    # (future, stop event, level, the plain mesh's ms, when it started) on the worker

    @property
    def value_range(self) -> tuple[float, float]:
        """The volume's smallest and largest values."""
        return self.extractor.value_range

    @property
    def shown(self) -> CpuMesh:
        """The mesh on show (`GpuSurface.shown`'s counterpart)."""
        return self._shown

    @property
    def mesh(self) -> GpuMesh:
        """The mesh on show as the renderer draws it."""
        return self._shown.mesh

    def extract(self, iso: float, options: MeshOptions, step: int = 1, wait: bool = True) -> None:
        """As GpuSurface.extract: the full mesh, or with `step` > 1 a preview from every step-th sample."""
        start = time.perf_counter()
        self.drop_pending()
        step = min(int(step), coarsest_step(self.volume.data.shape))
        self.made_preview = step > 1 and step not in self._previews
        if self.made_preview:
            self._previews[step] = self._make(subsampled(self.volume.checked, step),
                                              spacing=tuple(s * step for s in self.volume.spacing),
                                              gradient_direction=self.gradient_direction)
        extractor = self.extractor if step == 1 else self._previews[step]
        spacing = tuple(s * step for s in self.volume.spacing)
        field = self.extractor_field(extractor, step)
        level = as_level(iso, self.value_range)
        if options.cells == "tetrahedra":
            with threads_for(field.size):
                arrays = tetrahedra_function()(field, level, spacing, self._descent)
        elif options.topology == "trilinear":
            with threads_for(field.size):
                trilinear = self._trilinear_extractor(extractor, step)
                trilinear.extract(level)
            arrays = trilinear.read_mesh()
        else:
            with threads_for(field.size):
                extractor.extract(level)
            arrays = extractor.read_mesh()
        if options.smooth:
            verts, faces, normals, values = arrays
            arrays = smooth_projected(verts, faces, field, level, options.smooth, spacing, descent=self._descent,
                                      normals=normals, value_range=self.value_range)
        sharp = options.sharp is not None and step == 1 and options.cells == "cubes"
        self.shown_step, self.shown_cells, self.shown_sharp = step, options.cells, sharp
        if sharp and wait:
            sharpened = sharpen(arrays, self._signed_field(), spacing, options.sharp)
            self._shown.take(sharpened[:4], level, _ms_since(start), crisp_normals(*sharpened))
        else:
            self._shown.take(arrays, level, _ms_since(start))
            if sharp:   # the plain mesh shows until the worker's step is in (poll)
                self._start_sharp(arrays, spacing, options.sharp, level, start)
        self.full_triangles = self._shown.n_triangles * step * step

    def _trilinear_extractor(self, plain, step: int):
        """The extractor of the trilinear topology over the same samples as `plain` (made once per step)."""
        if step not in self._trilinear:
            from ...cpu.extractor import CpuExtractor
            volume = self.volume.checked if step == 1 else subsampled(self.volume.checked, step)
            self._trilinear[step] = CpuExtractor(volume, spacing=tuple(s * step for s in self.volume.spacing),
                                                 gradient_direction=self.gradient_direction, topology="trilinear")
        return self._trilinear[step]

    def _signed_field(self) -> np.ndarray:
        key = (id(self.volume.checked.data), self._descent)
        if self._field_key != key:
            self._field, self._field_key = signed_field(self.volume.checked.data, self._descent), key
        return self._field

    def _start_sharp(self, plain, spacing, angle: float, level: float, start: float) -> None:
        if self._worker is None:
            self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="isoscope sharp features")
        stop = threading.Event()
        future = self._worker.submit(_sharpen_step, plain, self._signed_field(), spacing, angle, stop)
        self._pending = (future, stop, level, start)

    def drop_pending(self) -> None:
        """Forget a step on the worker: it never starts, or stops at its next check, unseen."""
        if self._pending is not None:
            self._pending[0].cancel()
            self._pending[1].set()
            self._pending = None

    def extractor_field(self, extractor, step: int) -> np.ndarray:
        """The float32 samples `extractor` holds (its `field` where it has one)."""
        field = getattr(extractor, "field", None)
        if field is None:
            data = self.volume.checked.data[::step, ::step, ::step]
            field = np.ascontiguousarray(data, dtype=np.float32)
        return field

    @property
    def sharp_pending(self) -> bool:
        """Sharp features are being made on the worker; the plain mesh is on show meanwhile."""
        return self._pending is not None

    def poll(self) -> bool:
        """Bring in sharp features made on the worker; True when the mesh on show changed.  ValueError: the
        step failed (the plain mesh stays on show)."""
        if self._pending is None or not self._pending[0].done():
            return False
        future, _, level, start = self._pending
        self._pending = None
        sharpened = step_result(future)
        if sharpened is None:
            return False
        self._shown.take(sharpened[:4], level, _ms_since(start), crisp_normals(*sharpened))
        return True

    def settle(self) -> None:
        """Wait for sharp features being made on the worker, and show them."""
        if self._pending is not None:
            self._pending[0].result()
            self.poll()

    def release(self) -> None:
        """Stop the worker (dropping what it was making), release the extractors and free the mesh on show."""
        self.drop_pending()
        if self._worker is not None:
            self._worker.shutdown(wait=False, cancel_futures=True)
            self._worker = None
        self._field = None
        for extractor in (self.extractor, *self._previews.values(), *self._trilinear.values()):
            extractor.release()
        self._previews.clear()
        self._trilinear.clear()
        self._shown.release()


def _ms_since(start: float) -> float:
    return (time.perf_counter() - start) * 1000.0


def _sharpen_step(plain, field, spacing, angle, stop):
    """The worker's feature step: sharpen's result, or None once stopped."""
    try:
        return sharpen(plain, field, spacing, angle, stop=stop)
    except Stopped:
        return None
