"""`isoscope.isosurface`: the surface of a volume as the field holds a mesh, a `trimesh.Trimesh`."""
from __future__ import annotations

import numpy as np


def isosurface(volume, level=None, *, spacing=None, affine=None, gradient_direction="descent", labels=False,
               tetrahedra=False, world=True, **options):
    """The isosurface of `volume` at `level` as a ``trimesh.Trimesh``, in world coordinates.

    Parameters
    ----------
    volume : array_like, path, nibabel image, xarray.DataArray, or (array, affine)
        Anything ``isoscope`` opens: a numpy array, a memory map, a Zarr or dask array (read lazily
        where the extraction allows), a file or built-in name, a nibabel image (its affine gives RAS
        world coordinates), a DataArray (evenly spaced coordinates give spacing and origin).
    level : float, optional
        The iso value; default: the volume's own (a built-in's), else the middle of its value range.
    spacing : three floats, optional
        Overrides the input's own sample spacing.
    affine : (4, 4) array_like, optional
        Array index -> world matrix (overrides a nibabel image's).
    gradient_direction : {"descent", "ascent"}, default "descent"
        "descent": the object is where values are above the level.
    labels : bool, default False
        Treat `volume` as a label map: one surface per non-zero label in one mesh, each vertex coloured
        by its label (``mesh.visual.vertex_colors``), neighbours sharing their boundary.  It takes no
        `level`, `tetrahedra` or mesh option but ``backend`` (`isoscope.label_surfaces` says why).
    tetrahedra : bool, default False
        Marching tetrahedra's surface instead of marching cubes'.
    world : bool, default True
        Vertices in the input's world coordinates where it has them; False: array index x spacing.
    **options
        Passed to `isoscope.marching_cubes` (``smooth``, ``sharp_features``, ``step_size``, ``backend``, ...).

    Returns
    -------
    trimesh.Trimesh
        Outward-facing triangles (counter-clockwise seen from outside, whatever the affine's handedness)
        and vertex normals; ``pyvista.wrap(mesh)`` turns it into a PyVista PolyData.

    See Also
    --------
    isoscope.marching_cubes
        The arrays behind this mesh.
    isoscope.label_surfaces
        One surface per label (``labels=True`` here).
    isoscope.render
        A picture of the surface.
    isoscope.view
        The surface in the desktop window.

    Notes
    -----
    The vertices and faces are those `isoscope.api.outward_marching_cubes` returns (marching_cubes' vertices,
    wound outward; moved into world coordinates, the winding reversed where the affine mirrors, so triangles
    stay outward); trimesh does not merge or process them (``process=False``), so vertex *i* is
    marching_cubes' vertex *i*.

    References
    ----------
    .. [1] W. E. Lorensen and H. E. Cline, "Marching cubes: a high resolution 3D surface construction
       algorithm", SIGGRAPH 1987.
    .. [2] trimesh, https://trimesh.org: the mesh type returned.

    Examples
    --------
    >>> import numpy as np
    >>> import isoscope
    >>> x, y, z = np.mgrid[-1:1:41j, -1:1:41j, -1:1:41j]
    >>> ball = 0.5 - np.sqrt(x * x + y * y + z * z)
    >>> mesh = isoscope.isosurface(ball, 0.0, spacing=(0.05, 0.05, 0.05), backend="cpu")
    >>> bool(mesh.is_watertight), round(float(mesh.volume), 2)    # 4/3 pi 0.5^3 = 0.52
    (True, 0.52)
    """
    import trimesh

    from .io.export import in_volume_space
    from .volumes.inputs import as_volume
    shown = as_volume(volume, spacing=spacing, affine=affine, gradient_direction=gradient_direction)
    if labels:
        from .errors import InputError
        from .labels import coloured_join, label_colors, label_surfaces, labels_of
        # A label's surface is its boundary (label_surfaces): a level or a mesh mode would be silently dropped.
        dropped = ["level"] * (level is not None) + ["tetrahedra"] * bool(tetrahedra) + \
            [name for name in options if name != "backend"]
        if dropped:
            raise InputError(f"{dropped[0]} does not apply with labels=True (each label's surface is its boundary); "
                             f"leave out {dropped[0]}")
        # labels=True is the caller's word that it is a label map (as label_surfaces takes an array)
        surfaces = label_surfaces(labels_of(shown), spacing=shown.spacing, backend=options.get("backend", "auto"))
        parts = [in_volume_space(shown, *mesh, world=world)[:3] for mesh in surfaces.values()]
        if not parts:
            return trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), process=False)
        # Coloured in the labels' order, as the viewer colours them (a palette indexed by a label's value
        # allocated 2e9 colours for a label numbered 2e9).
        verts, faces, normals, rgba = coloured_join(parts, label_colors(len(parts)))
        return trimesh.Trimesh(verts, faces, vertex_normals=normals, vertex_colors=rgba, process=False)
    from .one_shot import cubes
    from .one_shot import tetrahedra as tetrahedra_extract
    from .validation import named_level
    from .volumes import VolumeError
    if level is not None:
        try:   # the command line's words, as view and render say it
            level = named_level(level, shown.value_range, shown.name)
        except ValueError as exc:
            raise VolumeError(str(exc)) from None
    extract = tetrahedra_extract if tetrahedra else cubes
    verts, faces, normals, _ = extract(shown.checked, level if level is not None else shown.default_level,
                                       spacing=shown.spacing, gradient_direction=shown.gradient_direction,
                                       **options)
    verts, faces, normals, _ = in_volume_space(shown, verts, faces, normals, world=world)
    return trimesh.Trimesh(verts, faces, vertex_normals=normals, process=False)
