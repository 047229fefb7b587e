"""`marching_cubes` (scikit-image's call) and `marching_tetrahedra`, on the GPU, compiled on the CPU or in numpy."""
from __future__ import annotations

import numpy as np

from . import one_shot, validation
from .cpu.smooth import check_iterations, smooth_projected
from .errors import InputError
from .one_shot import BACKENDS, METHODS

__all__ = ["BACKENDS", "METHODS", "Extractor", "marching_cubes", "marching_tetrahedra", "outward_marching_cubes",
           "smooth_mesh"]


def marching_cubes(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                   step_size=1, allow_degenerate=True, method="lewiner", backend="auto", smooth=0,
                   chunks=None, sharp_features=None, mask=None, topology="montani"):
    """Extract the isosurface ``volume == level`` as an indexed, watertight triangle mesh.

    A drop-in for ``skimage.measure.marching_cubes``: the same call, and a mesh wound and valued as its
    (isoscope's own outward mesh, as drawn and exported, is `outward_marching_cubes`).

    Parameters
    ----------
    volume : (I, J, K) array_like
        Every axis at least 2 long, finite values (or a `validation.CheckedVolume`,
        which is not scanned again).
    level : float, optional
        The iso value; default the middle of the data range.  Must lie within it.
    spacing : tuple of 3 floats, default (1.0, 1.0, 1.0)
        Voxel size along axes 0, 1, 2; vertices are scaled by it.
    gradient_direction : {"descent", "ascent"}, default "descent"
        "descent" when the object is where values are above the level
        (densities, CT), "ascent" when below (signed distances).  As in
        scikit-image, triangles wind clockwise seen from outside the object, and
        normals point down the gradient: out of it for "descent", into it for "ascent".
    step_size : int, default 1
        Sample every step_size-th grid point along each axis (a coarser, faster
        mesh in the same units); 1 is every sample.
    allow_degenerate : bool, default True
        Accepted for scikit-image's sake; this mesh never has degenerate
        (zero-area) triangles, so either value gives the same mesh.
    method : {"lewiner", "lorensen"}, default "lewiner"
        Accepted for scikit-image's sake; both give this extractor's mesh, whose
        case table resolves ambiguous faces from their four corners [2]_, so it is
        watertight as "lewiner" [4]_ is, and unlike "lorensen" [1]_ never has holes.
    backend : {"auto", "gpu", "cpu", "numpy"}, default "auto"
        "gpu" (OpenGL 4.3 compute shaders; a standalone EGL context when none is
        current), "cpu" (compiled CPU kernels, `isoscope.cpu.compiled`), "numpy"
        (the numpy reference extractor, `isoscope.cpu.cubes`), or "auto" (GPU where
        an OpenGL 4.3 context runs on graphics hardware, else "cpu", llvmpipe included:
        it runs the passes on the same cores, slower).  All give the same mesh.
    smooth : int, default 0
        Iterations of smoothing, each projected back onto the level set
        (`smooth_mesh`); 0 is the plain marching-cubes mesh.  A few iterations
        remove the sliver triangles; the faces stay the same.
    chunks : None, int or tuple of 3 ints, optional
        None (the whole volume at once), or N or (a, b, c): extract boxes of at
        most that many cells per axis (on the chosen backend), one at a time, and stitch them
        by global edge id into the same mesh (see `isoscope.big.chunked`).  Memory
        then grows with the box, not the volume: use it for volumes larger than
        the GPU or RAM (a memory-mapped array, ``np.load(path, mmap_mode="r")``,
        or a Zarr array is read a box at a time).
    sharp_features : float, optional
        None for plain marching cubes, or a feature angle in degrees
        (0 < angle < 180, e.g. 30): Extended Marching Cubes [3]_
        (`isoscope.core.sharp.features`) adds a vertex on the sharp edge or corner
        of each cell whose normals open wider than the angle, so boxes keep their
        edges.  The extra vertices come after the plain ones; the mesh stays
        watertight.  The plain mesh is made on the chosen backend; on "gpu" the
        feature step's per-patch solve runs there too (shaders/emc_solve.comp:
        the numpy mesh), the rest of it in numpy; on "cpu" and "numpy" all of the feature step in numpy.
    mask : (I, J, K) bool array, optional
        As in scikit-image, only the cells whose far corner (i + 1, j + 1, k + 1)
        the mask holds true get triangles, so the surface is open where it leaves
        the mask (`isoscope.core.masking`).
    topology : {"montani", "trilinear"}, default "montani"
        How ambiguous cells are decided.  "montani" decides every ambiguous face
        one way [2]_: watertight and fastest, but a thin neck or a tunnel between
        samples may be cut or closed wrongly.  "trilinear" gives the mesh the
        topology of the trilinear interpolant between the samples (MC33 [5]_):
        faces by the bilinear saddle, cells by the interior extremum of the
        sections' saddle value, tunnels as tubes (`isoscope.core.trilinear_table`),
        so pieces, cavities and handles (`isoscope.measure`) are the field's.
        The same vertices on the same edges, plus a vertex inside the few cells
        whose tube needs one.  Every backend makes the same mesh (the GPU's
        normals, as ever, within an ulp or so), and so does `chunks` (each
        cell is decided from its own samples, so a box decides it as the whole
        volume does); plain cubes only (no sharp features or mask).

    Returns
    -------
    verts : (N, 3) float32
        Vertex positions in array-index order times `spacing`.
    faces : (M, 3) int32
        Triangles as indices into `verts`, wound as scikit-image's.
    normals : (N, 3) float32
        Unit normals, pointing toward lower values (scikit-image's).
    values : (N,) float32
        As scikit-image computes them ("the maximum value of the data in the
        local region"): the largest spread, max - min, of the eight samples of
        the cells next to the vertex's grid edge (`isoscope.cpu.skimage_values`),
        taken before smoothing; a sharp-feature vertex takes the cells it lies in.

    Raises
    ------
    ValueError
        A volume, level or option the call cannot take; modes that do not go
        together (`isoscope.options.MeshOptionsError`, e.g. `smooth` with
        `sharp_features`) name the rule.

    See Also
    --------
    isoscope.marching_tetrahedra
        The same level set from the cells split into tetrahedra: no ambiguous cases.
    isoscope.smooth_mesh
        Smooths this mesh and projects it back onto the level.
    isoscope.Extractor
        Keeps the volume resident to extract many levels of it.
    isoscope.isosurface
        This mesh as a ``trimesh.Trimesh`` in world coordinates.
    isoscope.label_surfaces
        One surface per label of a label map.
    isoscope.find_contours
        The 2-D counterpart: contour lines of an image.

    Notes
    -----
    A sample is inside when it lies on the object's side of the level or on it:
    ties count as inside, and a vertex never lands on a grid point (it keeps
    1/256 of an edge off), so no two vertices coincide and no triangle has zero
    area.  Every grid edge whose ends lie on different sides of the level has
    exactly one vertex, shared by the triangles that use it.  Away from ties the
    vertices are scikit-image's (linear interpolation along the edge); the
    triangles may differ in the ambiguous cells, where the case table [2]_
    decides from the cell's faces.  Both backends give the same mesh.

    References
    ----------
    .. [1] W. E. Lorensen and H. E. Cline, "Marching cubes: a high resolution 3D
       surface construction algorithm", Computer Graphics (SIGGRAPH '87) 21(4),
       163-169, 1987.
    .. [2] C. Montani, R. Scateni and R. Scopigno, "A modified look-up table for
       implicit disambiguation of Marching Cubes", The Visual Computer 10(6),
       353-355, 1994.
    .. [3] L. P. Kobbelt, M. Botsch, U. Schwanecke and H.-P. Seidel, "Feature
       sensitive surface extraction from volume data", SIGGRAPH 2001, 57-66.
    .. [4] T. Lewiner, H. Lopes, A. W. Vieira and G. Tavares, "Efficient
       implementation of Marching Cubes' cases with topological guarantees",
       Journal of Graphics Tools 8(2), 1-15, 2003.
    .. [5] E. V. Chernyaev, "Marching cubes 33: construction of topologically
       correct isosurfaces", CERN CN/95-17, 1995.

    Examples
    --------
    A ball of radius 0.7 as a distance field: the object is where the values are
    below the level, so the gradient ascends out of it.

    >>> import numpy as np
    >>> import isoscope
    >>> x = np.mgrid[-1:1:20j, -1:1:20j, -1:1:20j]
    >>> distance = np.sqrt((x ** 2).sum(axis=0)).astype(np.float32)
    >>> verts, faces, normals, values = isoscope.marching_cubes(
    ...     distance, 0.7, gradient_direction="ascent", backend="cpu")
    >>> verts.shape, faces.shape, faces.dtype.name
    ((840, 3), (1676, 3), 'int32')

    A closed surface: every edge has two triangles, and the Euler characteristic
    is a sphere's.

    >>> edges = {tuple(sorted(e)) for a, b, c in faces.tolist() for e in ((a, b), (b, c), (c, a))}
    >>> len(verts) - len(edges) + len(faces)
    2

    scikit-image's mesh of the same ball has the same vertices, and the same values:

    >>> from skimage import measure
    >>> theirs = measure.marching_cubes(distance, 0.7, gradient_direction="ascent")
    >>> mine, its = np.lexsort(verts.T), np.lexsort(theirs[0].T)
    >>> bool(np.allclose(verts[mine], theirs[0][its], atol=1e-5)), bool(np.array_equal(values[mine], theirs[3][its]))
    (True, True)

    A box keeps its corners with sharp features: the plain mesh cuts each one off
    half a cell from it; Extended Marching Cubes puts a vertex on it.

    >>> box = np.abs(np.mgrid[-1:1:21j, -1:1:21j, -1:1:21j]).max(axis=0) - 0.45
    >>> plain = isoscope.marching_cubes(box, 0.0, gradient_direction="ascent", backend="cpu")[0]
    >>> sharp = isoscope.marching_cubes(box, 0.0, gradient_direction="ascent", backend="cpu",
    ...                                 sharp_features=30)[0]
    >>> corner = (14.5, 14.5, 14.5)
    >>> float(np.abs(plain - corner).max(axis=1).min()), float(np.abs(sharp - corner).max(axis=1).min())
    (0.5, 0.0)
    >>> bool(np.array_equal(sharp[:len(plain)], plain))  # the plain vertices come first
    True

    Two bright corners of one cell, joined through its middle: the trilinear
    interpolant has one piece there, a tube; Montani's rule cuts it in two.

    >>> cell = np.full((2, 2, 2), -0.25, np.float32)
    >>> cell[0, 0, 0] = cell[1, 1, 1] = 1.0
    >>> for topology in ("montani", "trilinear"):
    ...     _, faces, _, _ = isoscope.marching_cubes(cell, 0.0, backend="cpu", topology=topology)
    ...     print(topology, len(faces), "triangles")
    montani 2 triangles
    trilinear 6 triangles
    """
    verts, faces, normals, values = one_shot.cubes(
        volume, level, spacing=spacing, gradient_direction=gradient_direction, step_size=step_size, method=method,
        backend=backend, smooth=smooth, chunks=chunks, sharp_features=sharp_features, mask=mask, skimage=True,
        topology=topology)
    from .cpu.skimage_values import skimage_orientation  # the arrays are this call's own: turned in place
    return verts, *skimage_orientation(faces, normals, validation.as_gradient_direction(gradient_direction)), values


def outward_marching_cubes(volume, level=None, **options):
    """`marching_cubes`'s mesh (the same options) as isoscope draws, exports and measures it: the same vertices,
    triangles counter-clockwise seen from outside the object and normals out of it for either
    `gradient_direction`, `values` the volume at each vertex (the level, up to rounding and ties)."""
    options.pop("allow_degenerate", None)
    return one_shot.cubes(volume, level, **options)


def marching_tetrahedra(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                        backend="auto", smooth=0, mask=None):
    """Extract the isosurface ``volume == level`` by marching tetrahedra [1]_.

    Every cell is split into six tetrahedra along its main diagonal [2]_, the same
    way in every cell, so they meet face to face across cells (see
    `isoscope.cpu.tetra`).  Inside a tetrahedron the field is linear, so no cell
    is ambiguous: the surface is the level set of the piecewise-linear
    interpolant, watertight and 2-manifold by construction, at the price of about
    three times marching cubes' triangles and vertices.

    Parameters
    ----------
    volume, level, spacing, gradient_direction
        As for `marching_cubes`.
    backend : {"auto", "gpu", "cpu", "numpy"}, default "auto"
        "gpu", "cpu" (compiled CPU kernels), "numpy" (the numpy reference), or "auto",
        as for `marching_cubes`.
    smooth : int, default 0
        Iterations of smoothing projected back onto the level set, as in
        `marching_cubes`.
    mask : (I, J, K) bool array, optional
        Only cells where it is true get triangles, as in `marching_cubes`.

    Returns
    -------
    verts, faces, normals, values
        As from `outward_marching_cubes` (isoscope's outward winding; values the level).

    Raises
    ------
    ValueError
        As `marching_cubes`.

    See Also
    --------
    isoscope.marching_cubes
        The same level set from the cubes' case table.
    isoscope.smooth_mesh
        Smooths a mesh and projects it back onto the level.
    isoscope.isosurface
        A mesh as a ``trimesh.Trimesh`` (``tetrahedra=True``).

    Notes
    -----
    The conventions are `outward_marching_cubes`'s: ties count as inside, normals point
    out of the object, triangles wind counter-clockwise seen from outside.  Every
    edge of the tetrahedral grid (the three axes, the three face diagonals and the
    body diagonal of each cell) whose ends lie on different sides of the level has
    exactly one vertex.

    References
    ----------
    .. [1] H. Müller and M. Wehle, "Visualization of implicit surfaces using
       adaptive tetrahedrizations", Scientific Visualization Conference
       (Dagstuhl '97), 243-250, 1997.
    .. [2] H. Freudenthal, "Simplizialzerlegungen von beschränkter Flachheit",
       Annals of Mathematics 43(3), 580-582, 1942.

    Examples
    --------
    The ball of `marching_cubes`'s example:

    >>> import numpy as np
    >>> import isoscope
    >>> distance = np.linalg.norm(np.mgrid[-1:1:20j, -1:1:20j, -1:1:20j], axis=0).astype(np.float32)
    >>> verts, faces, normals, values = isoscope.marching_tetrahedra(
    ...     distance, 0.7, gradient_direction="ascent", backend="cpu")
    >>> verts.shape, faces.shape
    ((2486, 3), (4968, 3))
    >>> cubes = isoscope.marching_cubes(distance, 0.7, gradient_direction="ascent", backend="cpu")
    >>> round(len(faces) / len(cubes[1]), 1)  # about three times marching cubes' triangles
    3.0
    >>> edges = {tuple(sorted(e)) for a, b, c in faces.tolist() for e in ((a, b), (b, c), (c, a))}
    >>> len(verts) - len(edges) + len(faces)  # closed, a sphere's Euler characteristic
    2
    """
    return one_shot.tetrahedra(volume, level, spacing=spacing, gradient_direction=gradient_direction,
                               backend=backend, smooth=smooth, mask=mask)
def smooth_mesh(volume, verts, faces, level, iterations=5, *, spacing=(1.0, 1.0, 1.0),
                gradient_direction="descent", normals=None, backend="auto"):
    """Smooth a mesh on ``volume == level`` (e.g. from `marching_cubes`) and project it back onto the level set.

    Each of `iterations` rounds moves every vertex half-way to the average of its
    mesh neighbours (the umbrella operator [1]_), then pulls it back onto the
    level set of the volume's trilinear interpolant by Newton steps along the
    gradient (see `isoscope.cpu.smooth`).  Sliver triangles even out; the surface
    stays where the volume puts it (no shrinking, so no need for Taubin's
    inflating step [2]_), and the faces are kept.

    Parameters
    ----------
    volume : (I, J, K) array_like
        The volume the mesh was extracted from.
    verts : (N, 3) array_like
        Vertex positions in array-index order times `spacing`.
    faces : (M, 3) array_like of int
        Triangles as indices into `verts`.
    level : float
        The iso value the mesh lies on; must lie within the volume's range.
    iterations : int, default 5
        Rounds of smoothing and projection.
    spacing : tuple of 3 floats, default (1.0, 1.0, 1.0)
        Voxel size along axes 0, 1, 2, as for `marching_cubes`.
    gradient_direction : {"descent", "ascent"}, default "descent"
        Which side of the level is the object, as for `marching_cubes`.
    normals : (N, 3) array_like, optional
        Kept where the field is flat (its gradient vanishes); zeros if not given.
    backend : {"auto", "gpu", "cpu", "numpy"}, default "auto"
        As for `marching_cubes` ("cpu" and "numpy" both smooth in numpy); all give the same mesh.

    Returns
    -------
    verts : (N, 3) float32
        The smoothed positions.
    faces : (M, 3) int32
        The faces, unchanged.
    normals : (N, 3) float32
        Unit normals from the field's gradient at the new positions.
    values : (N,) float32
        The trilinear interpolant at the new positions.

    Raises
    ------
    ValueError
        A volume, level or iteration count the call cannot take, or faces that
        index past `verts`.

    See Also
    --------
    isoscope.marching_cubes
        The mesh to smooth (or ``smooth=True`` there).
    isoscope.marching_tetrahedra
        The other mesh it takes.

    Notes
    -----
    A vertex on the volume's border keeps its coordinate along that axis, a
    projection that would end further off the level than it started keeps the
    vertex where it was, and no move shrinks a triangle to zero area.

    References
    ----------
    .. [1] L. Kobbelt, S. Campagna, J. Vorsatz and H.-P. Seidel, "Interactive
       multi-resolution modeling on arbitrary meshes", SIGGRAPH 1998, 105-114.
    .. [2] G. Taubin, "A signal processing approach to fair surface design",
       SIGGRAPH 1995, 351-358.

    Examples
    --------
    >>> import numpy as np
    >>> import isoscope
    >>> distance = np.linalg.norm(np.mgrid[-1:1:20j, -1:1:20j, -1:1:20j], axis=0).astype(np.float32)
    >>> verts, faces, _, _ = isoscope.marching_cubes(distance, 0.7, gradient_direction="ascent", backend="cpu")
    >>> smoothed, same_faces, normals, values = isoscope.smooth_mesh(
    ...     distance, verts, faces, 0.7, 3, gradient_direction="ascent", backend="cpu")
    >>> bool(np.array_equal(same_faces, faces))
    True

    The vertices stay on the ball of radius 0.7 (the grid's centre is index 9.5,
    and 9.5 index steps span a distance of 1):

    >>> radius = np.linalg.norm(smoothed - 9.5, axis=1) / 9.5
    >>> bool(np.abs(radius - 0.7).max() < 0.005)
    True
    """
    iterations = check_iterations(iterations)
    backend = one_shot.backend_of(backend)
    checked = validation.check_volume(volume)
    spacing = validation.as_spacing(spacing)
    descent = validation.as_gradient_direction(gradient_direction)
    level = validation.as_level(level, checked.value_range)
    verts = np.ascontiguousarray(verts, np.float32).reshape(-1, 3)
    faces = np.ascontiguousarray(faces, np.int32).reshape(-1, 3)
    if faces.size and (faces.min() < 0 or faces.max() >= len(verts)):
        raise InputError(f"faces index vertices 0 .. {faces.max()}, but there are {len(verts)} vertices; "
                         "pass the faces of this mesh")
    normals = np.zeros_like(verts) if normals is None else np.ascontiguousarray(normals, np.float32).reshape(-1, 3)
    if backend in ("cpu", "numpy") or not len(faces):
        return smooth_projected(verts, faces, checked.data.astype(np.float32, copy=False), level, iterations,
                                spacing, descent=descent, normals=normals, value_range=checked.value_range)

    from .gpu.mesh import GpuMesh
    from .gpu.resident import ResidentVolume
    from .gpu.smooth import Smoother
    with ResidentVolume(checked, spacing=spacing, gradient_direction=gradient_direction) as resident:
        mesh = GpuMesh.upload(resident.ctx, verts, faces, normals)
        smoother = None
        try:
            smoother = Smoother(resident)
            smoother.smooth(mesh, iterations, level)
            return mesh.read()
        finally:
            if smoother is not None:
                smoother.release()
            mesh.release()


class _ExtractorKind(type):
    """`isinstance(x, isoscope.Extractor)` holds for the extractor of either backend it makes."""

    def __instancecheck__(cls, obj) -> bool:
        from .cpu.extractor import CpuExtractor
        from .gpu.cubes import Extractor as GpuExtractor
        return isinstance(obj, (CpuExtractor, GpuExtractor))


class Extractor(metaclass=_ExtractorKind):
    """Keeps one volume resident and extracts its marching-cubes isosurface at any level.

    ``isoscope.Extractor(volume, ...)`` makes the extractor of the backend asked for: the GPU's
    (`isoscope.gpu.cubes.Extractor`: the volume in a 3-D texture, the mesh in GL buffers) or the CPU's
    (`isoscope.cpu.extractor.CpuExtractor`: compiled kernels on the volume in memory).  Both answer the
    same calls and give the same mesh.

    Parameters
    ----------
    volume : (X, Y, Z) array_like or validation.CheckedVolume
        The samples; a CheckedVolume is taken without scanning it again.
    spacing : three floats, default (1, 1, 1)
        The distance between samples along each axis; vertices are in these units.
    gradient_direction : {"descent", "ascent"}, default "descent"
        As for `marching_cubes`: normals point out of the object.
    ctx : moderngl.Context, optional
        The GL context of the GPU extractor (default: the current one, else a standalone EGL context).
    table : CaseTable, optional
        The case table (default: the generated Montani table `marching_cubes` uses).
    limits : GpuLimits, optional
        The GPU extractor's limits, as `isoscope.gpu.cubes.Extractor` takes them.
    backend : {"auto", "gpu", "cpu", "numpy"}, default "auto"
        "gpu", "cpu" (compiled kernels), "numpy" (the numpy reference, for checking), or "auto": the
        GPU where `ctx` is given, a window's context is current, or OpenGL 4.3 runs on graphics
        hardware; else the compiled CPU extractor (without GL, and on a software renderer such as
        llvmpipe, whose compute passes run slower on the same CPU cores).
    topology : {"montani", "trilinear"}, default "montani"
        As for `marching_cubes`; on every backend (`isoscope.gpu.trilinear` on the GPU).

    Attributes
    ----------
    value_range : (float, float)
        The volume's smallest and largest values.
    shape, spacing, level
        The volume's shape, its spacing, and the level of the last extraction (None before one).
    mesh
        The last extraction: GL buffers (`GpuMesh`) on the GPU, the arrays on the CPU.

    Raises
    ------
    ValueError
        A volume, spacing, direction or backend the extractor cannot take (the same one-line
        messages on every backend), or `ctx` / `limits` with a CPU backend.
    GPULimitError
        On the GPU, a volume or mesh beyond the GL implementation's limits.

    See Also
    --------
    isoscope.marching_cubes
        One extraction from one call.
    isoscope.release_gpu_memory
        Frees the GPU extractor that one-shot calls keep for the next call.

    Notes
    -----
    `extract(level)` returns (vertices, triangles); `read_mesh()` returns (verts, faces, normals,
    values) as `outward_marching_cubes` does; `release()` or leaving a ``with`` block frees the volume and
    the mesh.  The CPU extractor measures each 32-sample row's value range on the first change of
    level, so that later levels read only the rows they cut (the GPU skips bricks the same way).

    Examples
    --------
    >>> import numpy as np
    >>> import isoscope
    >>> x, y, z = np.mgrid[-1:1:24j, -1:1:24j, -1:1:24j]
    >>> ball = (1 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)
    >>> with isoscope.Extractor(ball, backend="cpu") as extractor:
    ...     counts = extractor.extract(0.5)
    ...     verts, faces, normals, values = extractor.read_mesh()
    ...     second = extractor.extract(0.25)           # a new level: the volume stays resident
    >>> counts == (len(verts), len(faces)), second[1] > counts[1]
    (True, True)
    >>> bool(np.array_equal(faces, isoscope.api.outward_marching_cubes(ball, 0.5, backend="numpy")[1]))
    True
    """

    def __new__(cls, volume, spacing=(1.0, 1.0, 1.0), gradient_direction="descent", ctx=None, table=None,
                limits=None, *, backend="auto", topology="montani"):
        from .options import MeshOptions
        MeshOptions(topology=topology).check()
        if backend == "auto":
            from .gpu.context import resident_backend
            backend = resident_backend(ctx)
        backend = one_shot.backend_of(backend)
        if backend == "gpu":
            from .gpu.cubes import Extractor as GpuExtractor
            from .gpu.trilinear import TrilinearExtractor
            kind = TrilinearExtractor if topology == "trilinear" else GpuExtractor
            return kind(volume, spacing, gradient_direction, ctx=ctx, table=table, limits=limits)
        if ctx is not None or limits is not None:
            raise InputError(f"ctx and limits are the GPU extractor's; backend {backend!r} takes neither")
        from .cpu.extractor import CpuExtractor
        return CpuExtractor(volume, spacing, gradient_direction, backend=backend, table=table, topology=topology)
