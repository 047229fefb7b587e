"""The viewer from Python: `isoscope.render` draws a volume offscreen and hands back its pixels."""
from __future__ import annotations

import numpy as np


def render(volume, level=None, *, size=(800, 600), azimuth=None, elevation=None, spacing=None, affine=None,
           gradient_direction="descent", opacities=(), color_by=None, colormap=None, labels=False,
           tetrahedra=False, smooth=0, wireframe=False, panel=False, transparent=False) -> np.ndarray:
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
        The camera's angles in degrees (default -60 and 25).
    spacing, affine, gradient_direction
        As for `isoscope.isosurface`.
    opacities : sequence of float
        Each level's opacity, in order (translucent surfaces blend order-independently).
    color_by : {"value", "gradient"} or a volume of the same shape, optional
        Colour the surfaces by a scalar through `colormap` (a cmap name); a colour bar is drawn at the right.
    labels : bool
        Draw each non-zero label of a label map as its own coloured surface.
    tetrahedra, smooth, wireframe : mesh modes, as the command's flags.
    panel : bool
        Draw the viewer's panel over the scene.
    transparent : bool
        A transparent background (the alpha channel 0 where nothing is drawn).

    Returns
    -------
    (height, width, 4) uint8 array
        RGBA pixels, top row first (alpha 255 everywhere unless `transparent`).

    Examples
    --------
    >>> import numpy as np
    >>> import isoscope
    >>> x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
    >>> image = isoscope.render(0.6 - np.sqrt(x * x + y * y + z * z), 0.0, size=(160, 120))
    >>> image.shape, image.dtype
    ((120, 160, 4), dtype('uint8'))
    """
    from ..volumes.inputs import as_volume
    from .gfx.colorbar import draw_colorbar
    from .ui.headless import labels_pixels, prepared_viewer
    shown = as_volume(volume, spacing=spacing, affine=affine, gradient_direction=gradient_direction)
    size = (int(size[0]), int(size[1]))
    if labels:
        pixels = labels_pixels(shown, size, azimuth, elevation, transparent)
    else:
        viewer = prepared_viewer(shown, list(level) if isinstance(level, (list, tuple)) else level, size, azimuth,
                                 elevation, transparent, opacities, color_by, colormap, None, tetrahedra, smooth,
                                 wireframe)
        try:
            pixels = viewer.render(panel=panel)
            if viewer.state.color_by is not None and not panel:
                pixels = draw_colorbar(pixels, viewer.state.color_by)
        finally:
            viewer.release()
    if pixels.shape[2] == 3:
        pixels = np.concatenate([pixels, np.full(pixels.shape[:2] + (1,), 255, np.uint8)], axis=2)
    return pixels
