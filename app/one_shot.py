"""One-shot extraction on the backend asked for: the engine under `isoscope.marching_cubes`,
`marching_tetrahedra`, `outward_marching_cubes`, and what inside the package extracts a mesh once (export,
the closed surfaces, label maps).  The public functions and their documentation are `isoscope.api`'s.

The volume is checked once (`validation.check_volume`), its values left unscanned where the extractor
reads every sample anyway; the mesh is made by the compiled CPU kernels (reading the samples in place, in
their own type and memory order: `isoscope.cpu.samples`), the numpy reference, or the GPU, and smoothed,
sharpened or masked as asked.
"""
from __future__ import annotations

import numpy as np

from . import validation
from .core.joined import joined
from .core.masking import check_mask, keep_masked_cells
from .core.sharp.features import check_feature_angle, sharpen_extracted
from .cpu.cubes import marching_cubes_reference
from .cpu.smooth import check_iterations, smooth_projected
from .cpu.tetra import marching_tetrahedra_reference
from .errors import InputError
from .options import MeshOptions

BACKENDS = ("auto", "gpu", "cpu", "numpy")
METHODS = ("lewiner", "lorensen")


def cubes(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent", step_size=1,
         method="lewiner", backend="auto", smooth=0, chunks=None, sharp_features=None, mask=None, skimage=False,
         topology="montani"):
    """`isoscope.marching_cubes`'s options, checked here: the outward mesh (`outward_marching_cubes`);
    `skimage`: with scikit-image's values (`isoscope.cpu.skimage_values`)."""
    iterations = check_iterations(smooth)
    if method not in METHODS:
        raise InputError(f"method {method!r} is not one of {METHODS}")
    angle = check_feature_angle(sharp_features)
    MeshOptions(smooth=iterations, sharp=angle, masked=mask is not None, chunked=chunks is not None,
                topology=topology).check()
    trilinear = topology == "trilinear"
    chosen = backend == "auto"
    backend = backend_of(backend)
    if chunks is not None:
        return _chunked(volume, level, spacing, gradient_direction, step_size, backend, chunks, skimage, topology)
    # The plain GPU mesh of every sample leaves the value scan to the upload; the compiled CPU extractor
    # measures the values in its first pass (_checked).
    every_sample = isinstance(step_size, (int, np.integer)) and step_size == 1
    on_cpu = backend in ("cpu", "numpy")
    checked = _checked(volume, backend, level, gpu_scans=angle is None and every_sample)
    step = validation.as_step_size(step_size)
    spacing = validation.as_spacing(spacing)
    descent = validation.as_gradient_direction(gradient_direction)
    if checked.value_range is not None:
        level = validation.as_level(level, checked.value_range)
    mask = check_mask(mask, checked.samples.shape)
    if step > 1:
        checked = validation.subsampled(checked, step)
        spacing = tuple(s * step for s in spacing)
    def values_of(verts, level):  # scikit-image's, of the plain vertices (before smoothing moves them)
        from .cpu.skimage_values import skimage_values  # numba loads on first use
        return skimage_values(checked.samples, verts, level, spacing, mask, step)

    plain_values = values_of if skimage and angle is None else None

    def on_cpu_with(backend):
        return _on_cpu(backend, False, checked, level, spacing, descent, iterations, plain_values,
                       fused_values=plain_values is not None and mask is None and not trilinear, trilinear=trilinear)

    if on_cpu:
        mesh = on_cpu_with(backend)
    elif angle is not None:
        from .gpu.sharp_features import marching_cubes_sharp_gpu
        mesh = marching_cubes_sharp_gpu(checked, level, spacing, gradient_direction, angle)
    else:
        from .gpu.limits import GPULimitError
        try:
            mesh = _on_gpu(checked, level, spacing, gradient_direction, iterations, False, plain_values,
                           trilinear=trilinear)
        except GPULimitError:
            if not chosen:
                raise
            # "auto" chose the GPU, whose passes cannot hold this mesh (the trilinear topology's own vertices
            # need one storage block): the compiled CPU extractor makes the same mesh.
            mesh = on_cpu_with("cpu")
    if mask is not None:
        return keep_masked_cells(mesh, mask, spacing, step)
    if angle is None:
        return mesh
    if on_cpu:
        mesh = sharpen_extracted(mesh, checked.data, spacing, descent, angle)[:4]
    return (*mesh[:3], values_of(mesh[0], level)) if skimage else mesh


def tetrahedra(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent", backend="auto",
               smooth=0, mask=None):
    """`isoscope.marching_tetrahedra`'s mesh (its options, checked here)."""
    iterations = check_iterations(smooth)
    backend = backend_of(backend)
    checked = _checked(volume, backend, level, gpu_scans=True)
    mask = check_mask(mask, checked.samples.shape)
    MeshOptions(cells="tetrahedra", smooth=iterations, masked=mask is not None).check()
    spacing = validation.as_spacing(spacing)
    descent = validation.as_gradient_direction(gradient_direction)
    if checked.value_range is not None:
        level = validation.as_level(level, checked.value_range)
    if backend in ("cpu", "numpy"):
        mesh = _on_cpu(backend, True, checked, level, spacing, descent, iterations)
    else:
        mesh = _on_gpu(checked, level, spacing, gradient_direction, iterations, tetrahedra=True)
    return mesh if mask is None else keep_masked_cells(mesh, mask, spacing)


def _checked(volume, backend: str, level, gpu_scans: bool) -> validation.CheckedVolume:
    """check_volume for a one-shot call on `backend`: the values of an array in memory are left unscanned
    where the extractor reads them anyway (the compiled CPU extractor's first pass, the GPU's upload of a
    plain mesh: `gpu_scans`), unless `level` is None and its middle is needed first."""
    if level is None or backend == "numpy" or (backend == "gpu" and not gpu_scans):
        return validation.check_volume(volume)
    if backend == "cpu":
        return validation.check_volume(volume, scan_values=False, deferred=validation.CPU_SCANNED_DTYPES)
    return validation.check_volume(volume, scan_values=False)


def _on_cpu(backend, tetrahedra, checked, level, spacing, descent, iterations, values_of=None, fused_values=False,
            trilinear=False):
    """A CPU extractor's mesh (`backend` "cpu": compiled, reading the samples in place; "numpy": the
    reference; cubes or `tetrahedra`), smoothed `iterations` times; `values_of(verts, level)`: its values
    from the plain vertices, in place of the extractor's, or with `fused_values` (scikit-image's values,
    no mask) made by the compiled extractor as it writes the vertices.  A volume left unscanned
    (value_range None) has its range measured in the compiled extractor's first pass and `level` held to
    it there.  `trilinear`: cubes with the trilinear interpolant's topology (`isoscope.cpu.trilinear`)."""
    value_range = checked.value_range
    fused_values = fused_values and backend == "cpu"
    if backend == "numpy":
        field = checked.data.astype(np.float32, copy=False)
        extract = marching_tetrahedra_reference if tetrahedra else marching_cubes_reference
        if trilinear:
            from .cpu.trilinear import marching_cubes_trilinear as extract
        verts, faces, normals, values = extract(field, level, spacing, descent)
    else:
        from .cpu.compiled import CompiledCubes  # numba loads on first use
        if trilinear:
            from .cpu.compiled_trilinear import CompiledTrilinear
            cubes = CompiledTrilinear(checked.samples, spacing, descent, value_range=value_range)
        else:
            cubes = CompiledCubes(checked.samples, spacing, descent, tetrahedra=tetrahedra, value_range=value_range)
        if value_range is None:
            level = validation.as_level(level, (-np.inf, np.inf))  # a finite number; the range comes next
        verts, faces, normals, values = cubes.extract(
            level, accept=lambda measured: validation.accept_measured(checked, measured, level),
            skimage_values=fused_values)
        value_range = cubes.value_range
    if values_of is not None and not fused_values:
        values = values_of(verts, level)
    if iterations:
        field = checked.data.astype(np.float32, copy=False)
        smoothed = smooth_projected(verts, faces, field, level, iterations, spacing, descent=descent,
                                    normals=normals, value_range=value_range)
        return smoothed if values_of is None else (*smoothed[:3], values)
    return verts, faces, normals, values


def _on_gpu(checked, level, spacing, gradient_direction, iterations, tetrahedra, values_of=None, trilinear=False):
    """Upload, extract (cubes, tetrahedra or the trilinear topology's cubes from the same resident volume),
    smooth, read back."""
    from .gpu.pool import pooled_extractor
    bad_level = None
    with pooled_extractor(checked, spacing, gradient_direction) as cubes:
        if checked.value_range is None:  # its values were scanned on upload
            try:
                level = validation.as_level(level, cubes.value_range)
            except ValueError as exc:
                bad_level = exc  # raised once the extractor is back in the pool, intact
        if bad_level is None:
            return _extract_and_read(cubes, level, iterations, tetrahedra, values_of, trilinear)
    raise bad_level


def _extract_and_read(cubes, level, iterations, tetrahedra, values_of=None, trilinear=False):
    """Extract at `level` from the resident volume of `cubes` (or from a TetraExtractor or trilinear-topology
    extractor on it), smooth, read back; `values_of` as for `_on_cpu`."""
    from .gpu.smooth import Smoother
    from .gpu.tetra import TetraExtractor
    from .gpu.trilinear import trilinear_on
    extractor = TetraExtractor(cubes) if tetrahedra else trilinear_on(cubes) if trilinear else cubes
    borrowed = extractor is not cubes
    smoother = None
    try:
        extractor.extract(level)
        values = None
        if values_of is not None:  # read before smoothing moves the vertices off their grid edges
            values = values_of(extractor.read_mesh()[0], level)
        if iterations:
            smoother = Smoother(extractor)
            smoother.smooth(extractor.mesh, iterations)
        mesh = extractor.read_mesh()
        return mesh if values is None else (*mesh[:3], values)
    finally:
        if smoother is not None:
            smoother.release()
        if borrowed:
            extractor.release()


def backend_of(backend: str, allowed=BACKENDS) -> str:
    """`backend` checked; "auto" made the one-shot choice of this process (gpu.context.one_shot_backend)."""
    if backend not in allowed:  # "auto": a one-shot call's, as gpu.context.one_shot_backend decides
        raise InputError(f"backend {backend!r} is not one of {allowed}")
    from .gpu.context import one_shot_backend
    return one_shot_backend() if backend == "auto" else backend


def _chunked(volume, level, spacing, gradient_direction, step_size, backend, chunks, skimage=False,
             topology="montani"):
    from .big.chunked import as_chunks, marching_cubes_chunked, value_range
    from .core.lazy_arrays import is_lazy
    if step_size != 1:
        raise InputError("chunks= runs at step_size 1; drop chunks, or use step_size=1")
    source = volume.data if isinstance(volume, validation.CheckedVolume) else volume
    if not is_lazy(source):
        source = validation._numeric_3d(source, "volume")[0]  # shape and dtype only: no scan of the values
    as_chunks(chunks, source.shape)
    spacing = validation.as_spacing(spacing)
    descent = validation.as_gradient_direction(gradient_direction)
    known = volume.value_range if isinstance(volume, validation.CheckedVolume) else None
    if known is None and level is not None:
        known = (-np.inf, np.inf)  # not scanned for a range: boxes the level misses give no surface
    level = validation.as_level(level, known or value_range(source, chunks))
    mesh = marching_cubes_chunked(source, level, spacing, descent, chunks, backend=backend, topology=topology)
    if not skimage:
        return mesh
    from .cpu.skimage_values import skimage_values
    return (*mesh[:3], skimage_values(source, mesh[0], level, spacing))


def extraction_of(cells: str, topology: str = "montani"):
    """The extraction isoscope draws, exports and measures: outward-wound cubes (the public `marching_cubes`
    is scikit-image's drop-in, wound the other way) of the `topology` asked for, or marching tetrahedra."""
    from functools import partial
    return tetrahedra if cells == "tetrahedra" else partial(cubes, topology=topology)


def closed_mesh(volume, level: float, cells: str = "cubes", smooth: int = 0, topology: str = "montani",
                sharp: float | None = None, backend: str = "cpu"):
    """(verts, faces, normals, values) of `volume` (a Volume) at `level` extracted whole from the volume padded on the
    outside of the level (core/closing.py), as `export --closed` does: watertight at the border; index x spacing
    coordinates.  `sharp`: the feature angle of sharp features (cubes), or None."""
    from .core.closing import padded_for_closing, unpad
    level = validation.as_level(level, volume.value_range)   # the padding moves the range: the level first
    data = padded_for_closing(volume.checked.data, volume.value_range, volume.gradient_direction == "descent")
    options = {} if sharp is None else {"sharp_features": sharp}
    verts, faces, normals, values = extraction_of(cells, topology)(
        data, level, spacing=volume.spacing, backend=backend, gradient_direction=volume.gradient_direction,
        smooth=smooth, **options)
    return unpad(verts, volume.spacing), faces, normals, values


EMPTY_MESH = (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int64), np.zeros((0, 3), np.float32),
              np.zeros(0, np.float32))


def border_caps(data, level: float, spacing=(1.0, 1.0, 1.0), gradient_direction: str = "descent", value_range=None,
                cells: str = "cubes"):
    """(verts, faces, normals, values) of the caps closing the surface `data == level` at the volume's border (what
    `closed_mesh` adds to the open surface, from the padding's slabs alone: core/closing.py), in index x spacing
    coordinates (the extractor's); empty where the surface stays inside."""
    from .core.closing import all_outside, far_value, slab_samples, slabs
    descent = gradient_direction == "descent"
    if value_range is None:
        value_range = (float(np.min(data)), float(np.max(data)))
    far = far_value(value_range, descent)
    spacing = np.asarray(spacing, np.float64)
    extract = extraction_of(cells)
    parts = []
    for ranges in slabs(np.shape(data)):
        samples = slab_samples(data, ranges, far)
        if min(samples.shape) < 2 or all_outside(samples, level, descent):
            continue
        verts, faces, normals, values = extract(samples, level, spacing=tuple(spacing), backend="cpu",
                                                gradient_direction=gradient_direction)
        if not len(faces):
            continue
        offset = (np.array([lo for lo, _ in ranges], np.float64) - 1.0) * spacing
        parts.append(((verts + offset).astype(np.float32), faces, normals, values))
    if not parts:
        return EMPTY_MESH
    return joined(parts, np.int64)
