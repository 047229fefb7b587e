"""The viewer from Python: `isoscope.view` opens the window on a volume and says what the user ended with;
`isoscope.render` draws a volume offscreen and hands back its pixels."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.numbers import AZIMUTH, ELEVATION, SMOOTH, image_size
from ..errors import InputError
from ..options import MeshOptions


@dataclass(frozen=True)
class Viewed:
    """What the window showed when it was closed: pick a threshold by eye, then go on in the script."""
    level: float                           # the selected level
    levels: tuple[float, ...]              # every level, in the panel's order
    azimuth: float                         # the camera, degrees
    elevation: float
    slices: tuple[int | None, int | None, int | None]   # each axis' slice index where one is shown
    volume: str                            # the name of the volume on show (the user may open another)
    shown_shape: tuple[int, int, int] | None = None   # the samples along each axis of the surface on screen:
    # the volume's own shape when it was shown at full resolution, fewer where the memory budget or a
    # preview (a level still moving) showed every Nth sample


def checked_levels(shown, level):
    """`level` (None: the volume's own, a number, or a sequence of up to MAX_LEVELS of them) if each lies in
    the volume's value range; else the command line's one line (`isoscope render --iso`), as a ValueError."""
    from ..volumes import VolumeError
    from .model.levels import MAX_LEVELS
    several = isinstance(level, (list, tuple, np.ndarray))
    levels = list(np.ravel(level)) if several else [level]
    if len(levels) > MAX_LEVELS:
        raise VolumeError(f"{len(levels)} levels given; at most {MAX_LEVELS} surfaces at once")
    from ..validation import named_level
    try:
        checked = [None if value is None else named_level(value, shown.value_range, shown.name) for value in levels]
    except ValueError as exc:
        raise VolumeError(str(exc)) from None
    return checked if several else level


def view(volume, level=None, *, spacing=None, affine=None, gradient_direction="descent", labels=False,
         size=(1280, 800), max_frames: int | None = None, memory_budget=None) -> Viewed:
    """Open the desktop window on `volume` and block until it is closed, as ``plt.show()`` does.

    Parameters
    ----------
    volume : array_like, path, nibabel image, xarray.DataArray, or (array, affine)
        What `isoscope.isosurface` takes.
    level : float, optional
        The first iso value (default: the volume's own).
    spacing, affine, gradient_direction
        As for `isoscope.isosurface`.
    labels : bool
        Show a label map's labels, each its own surface.
    size : (width, height)
        The window's size in screen pixels.
    max_frames : int, optional
        Close after this many frames (scripts and tests); None: when the user closes it.
    memory_budget : int or str, optional
        The memory the volume on show may take, in bytes or as a size such as "4G" (default: the GPU's
        free memory where its driver reports it, else 2 GiB; half the free RAM on a software renderer).
        A volume over it is shown at every Nth sample along each axis.

    Returns
    -------
    Viewed
        The selected level and all levels, the camera's angles, the slices on show and `shown_shape` (the
        samples of the surface on screen) when the window closed: ``level = isoscope.view(ct).level``.

    Raises
    ------
    isoscope.IsoscopeError
        No display or no OpenGL to open a window with (one line saying so), or a bad volume.

    See Also
    --------
    isoscope.render
        The same picture offscreen, as pixels.
    isoscope.widget
        The viewer in a Jupyter notebook.

    Examples
    --------
    Needs a display and a person, so not run as a doctest:

    >>> level = isoscope.view(ct).level   # doctest: +SKIP
    """
    from ..core.budget import requested_budget, using_budget
    from ..volumes.inputs import as_volume
    from .ui.window import ViewerWindow
    budget = requested_budget(memory_budget, "memory_budget")
    size = image_size(size, "size")
    shown = as_volume(volume, spacing=spacing, affine=affine, gradient_direction=gradient_direction)
    with using_budget(budget):
        window = ViewerWindow(shown, checked_levels(shown, level), size=size)
    state, camera = window.state, window.camera
    try:
        if labels:
            state.show_labels(force=True)   # labels=True: the caller's word, as isosurface takes it
    except BaseException:
        window.close()
        raise
    window.run(max_frames=max_frames)
    slices = tuple(index if on else None for on, index in zip(state.slices.shown, state.slices.index))
    return Viewed(level=float(state.iso), levels=tuple(float(item.value) for item in state.levels.items),
                  azimuth=float(camera.azimuth), elevation=float(camera.elevation), slices=slices,
                  volume=state.volume.name if state.volume is not None else shown.name,
                  shown_shape=window.scene.stats.shown_shape)


def render(volume, level=None, *, size=(800, 600), azimuth=None, elevation=None, spacing=None, affine=None,
           gradient_direction="descent", opacities=(), color_by=None, colormap=None, labels=False,
           label_names=None, slices=(), clip=None, tetrahedra=False, smooth=0, wireframe=False, panel=False,
           transparent=False, letters=False, memory_budget=None, raycast=None, transfer=None,
           with_surfaces=False, topology="montani") -> np.ndarray:
    """Render `volume`'s surface(s) offscreen, as ``isoscope render`` does, and return the pixels.

    Parameters
    ----------
    volume : array_like, path, nibabel image, xarray.DataArray, or (array, affine)
        What `isoscope.isosurface` takes.
    level : float or sequence of floats, optional
        The iso value, or up to 4 of them (several surfaces); default: the volume's own.
    size : (width, height), default (800, 600)
        The image size in pixels, as the command's ``--size WxH``.
    azimuth, elevation : float, optional
        The camera's angles in degrees.  Default: for a scan with a patient frame (an affine, a nibabel
        image, a NIfTI/NRRD/DICOM file) the anatomical view from anterior (azimuth -90, elevation 0: superior
        up, the patient's right on the picture's left); for a plain array -60 and 25.
    spacing, affine, gradient_direction
        As for `isoscope.isosurface`.
    opacities : sequence of float
        Each level's opacity, in order (translucent surfaces blend order-independently).
    color_by : {"value", "gradient"} or a volume of the same shape, optional
        Colour the surfaces by a scalar through `colormap` (a cmap name); a colour bar is drawn at the right.
    labels : bool
        Draw each non-zero label of a label map as its own coloured surface, as ``isoscope render --labels``
        does (the same picture): named and coloured by `label_names`.
    label_names : path, optional
        A label names file (ITK-SNAP, 3D Slicer colour table, FreeSurfer LUT, or JSON) giving each label's
        name and colour; default: the one beside the volume's file, if any.
    slices : sequence of (axis, index)
        Slices to show, as ``--slice``: axis 0, 1, 2 or "x", "y", "z"; the last one is also drawn in 2-D.
    clip : (axis, position) or (axis, position, hide_above), optional
        Hide the surface where the axis index is above `position` (below it with ``hide_above=False``),
        as ``--clip AXIS=POS[:+|-]``; the cut is capped.
    tetrahedra, smooth, wireframe, topology : mesh modes, as the command's flags (``topology="trilinear"``:
        the field's own topology between the samples, as `isoscope.marching_cubes` takes it).
    panel : bool
        Draw the viewer's panel over the scene.
    transparent : bool
        A transparent background (the alpha channel 0 where nothing is drawn).
    letters : bool
        A scan's orientation letters (R/L, A/P, S/I) at the picture's edges, as ``--orientation-letters``.
    memory_budget : int or str, optional
        As for `isoscope.view` (``--memory-budget``): a volume over it is drawn from every Nth sample.
    raycast : {"mip", "minip", "mean", "iso", "dvr"}, optional
        Draw the volume itself by ray casting in the surfaces' place, as ``--raycast``: the largest,
        smallest or mean value along each ray (through the slices' colour map and window), the level's
        first hit (shaded, no mesh made), or emission-absorption rendering.
    transfer : str or sequence of (value, opacity), optional
        With ``raycast="dvr"``: the opacity at each value, linear between the points (in increasing value,
        inside the volume's range), or a preset: "ct-bone", "ct-soft" (Hounsfield units), "mri".
    with_surfaces : bool, optional
        With `raycast`: draw the surfaces too, as ``--with-surfaces``: the opaque ones and the slices first,
        ending the rays (MIP and mean cover them as much as they are bright, MinIP as it is dark, DVR by its
        opacity), the translucent ones blended over the volume after it.

    Returns
    -------
    (height, width, 4) uint8 array
        RGBA pixels, top row first (alpha 255 everywhere unless `transparent`).

    See Also
    --------
    isoscope.view
        The desktop window on the same volume.
    isoscope.widget
        The viewer in a Jupyter notebook.
    isoscope.isosurface
        The mesh itself, as a ``trimesh.Trimesh``.

    Examples
    --------
    >>> import numpy as np
    >>> import isoscope
    >>> x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
    >>> image = isoscope.render(0.6 - np.sqrt(x * x + y * y + z * z), 0.0, size=(160, 120))
    >>> image.shape, image.dtype
    ((120, 160, 4), dtype('uint8'))
    """
    from ..core.budget import requested_budget, using_budget
    from ..volumes.inputs import as_volume
    from .model.raycast import check_transfer_mode
    from .ui.headless import prepared_viewer
    budget = requested_budget(memory_budget, "memory_budget")
    size = image_size(size, "size")
    azimuth = None if azimuth is None else AZIMUTH.check(azimuth, "azimuth")
    elevation = None if elevation is None else ELEVATION.check(elevation, "elevation")
    smooth = SMOOTH.check(smooth, "smooth")   # before a GL context is made: the refusal needs none
    MeshOptions(cells="tetrahedra" if tetrahedra else "cubes", smooth=smooth, topology=topology).check()
    check_transfer_mode(raycast, transfer)
    shown = as_volume(volume, spacing=spacing, affine=affine, gradient_direction=gradient_direction)
    if labels and level is not None:
        raise InputError("labels=True draws every label's surface; leave out the level")
    modes = {"tetrahedra": tetrahedra, "smooth": smooth, "topology": topology != "montani"}
    dropped = [name for name, given in modes.items() if labels and given]
    if dropped:   # as render --labels: a label's surface is its boundary, the mode would be silently dropped
        raise InputError(f"{dropped[0]} does not apply with labels=True (each label's surface is its boundary); "
                         f"leave out {dropped[0]}")
    if not labels and label_names is not None:
        raise InputError("label_names goes with labels=True")
    level = None if labels else checked_levels(shown, level)

    def prepare(state) -> None:   # as the command's apply_slice_arguments and --labels
        """Put the slices, clip and labels asked for on the viewer's state before the picture is drawn."""
        for axis, index in slices:
            state.slices.show(_axis(axis), True, index)
        if clip is not None:
            state.slices.set_clip(_axis(clip[0]), *clip[1:])
        if labels:
            state.show_labels(names=label_names, force=True)

    with using_budget(budget):
        viewer = prepared_viewer(shown, level, size, azimuth, elevation, transparent, opacities, color_by,
                                 colormap, prepare, tetrahedra, smooth, wireframe, raycast=raycast,
                                 transfer=transfer, with_surfaces=with_surfaces, topology=topology)
    try:
        pixels = viewer.picture(panel=panel, letters=letters)
    finally:
        viewer.release()
    if pixels.shape[2] == 3:
        pixels = np.concatenate([pixels, np.full(pixels.shape[:2] + (1,), 255, np.uint8)], axis=2)
    return pixels


def _axis(axis) -> int:
    """0, 1, 2 or "x", "y", "z" -> 0, 1, 2."""
    from .model.slices import AXES
    if isinstance(axis, str) and axis.strip().lower() in AXES:
        return AXES.index(axis.strip().lower())
    if axis in (0, 1, 2):
        return int(axis)
    raise InputError(f"axis {axis!r} is not 0, 1, 2 or x, y, z")
