"""`isoscope.widget`: the viewer in a Jupyter notebook, a jupyter_rfb canvas drawn offscreen by the same
renderer as `isoscope render`, a level slider, and the window's mouse (left drag orbits, right drag pans,
the wheel zooms).  `pip install "isoscope[notebook]"` brings ipywidgets and jupyter-rfb."""
from __future__ import annotations

import numpy as np


def widget(volume, level=None, *, size=(640, 480), spacing=None, affine=None, gradient_direction="descent",
           memory_budget=None, **options):
    """An ipywidgets box showing `volume`'s surface: ``.canvas`` (a jupyter_rfb RemoteFrameBuffer whose
    ``get_frame()`` is the current picture), ``.slider`` (the iso value) and ``.viewer`` (the headless
    viewer drawing it).  `options` are `isoscope.render`'s mesh and look options (opacities, color_by,
    colormap, tetrahedra, smooth, wireframe, raycast: the volume itself, ray cast, with_surfaces: the
    surfaces with it, transfer); `memory_budget` as
    `isoscope.view`'s.  Call ``.close_viewer()`` to free its GL resources.

    See Also
    --------
    isoscope.render
        One picture with the same options.
    isoscope.view
        The desktop window.
    """
    ipywidgets = _needed("ipywidgets")
    RemoteFrameBuffer = _needed("jupyter_rfb").RemoteFrameBuffer
    from ..core.budget import requested_budget, using_budget
    from ..core.numbers import image_size
    from ..volumes.inputs import as_volume
    from .scripting import checked_levels
    from .ui.headless import prepared_viewer

    budget = requested_budget(memory_budget, "memory_budget")
    size = image_size(size, "size")
    shown = as_volume(volume, spacing=spacing, affine=affine, gradient_direction=gradient_direction)
    with using_budget(budget):
        viewer = prepared_viewer(shown, checked_levels(shown, level), size, **options)

    class Canvas(RemoteFrameBuffer):
        """The scene, drawn on request; pointer events move the camera as in the window."""

        def __init__(self):
            super().__init__(css_width=f"{size[0]}px", css_height=f"{size[1]}px", resizable=False)
            self._last: tuple[float, float] | None = None
            self._button = 0

        def get_frame(self) -> np.ndarray:
            """The current picture, RGB."""
            return np.ascontiguousarray(viewer.render()[..., :3])

        def handle_event(self, event: dict) -> None:
            """Orbit on a left drag, pan on another drag, zoom on the wheel, as in the window; then draw again."""
            kind = event.get("type") or event.get("event_type")
            if kind == "pointer_down":
                self._last, self._button = (event["x"], event["y"]), int(event.get("button", 1))
            elif kind == "pointer_up":
                self._last = None
            elif kind == "pointer_move" and self._last is not None:
                dx, dy = event["x"] - self._last[0], event["y"] - self._last[1]
                self._last = (event["x"], event["y"])
                if self._button == 1 and not event.get("modifiers"):
                    viewer.camera.orbit(dx, dy)
                else:
                    viewer.camera.pan(dx, dy, viewer.size[1])
                self.request_draw()
            elif kind == "wheel":
                viewer.camera.zoom(-float(event.get("dy", 0.0)) / 100.0)
                self.request_draw()

    canvas = Canvas()
    low, high = shown.value_range
    slider = ipywidgets.FloatSlider(value=float(viewer.state.iso), min=low, max=high, step=(high - low) / 1000,
                                    description="level", continuous_update=True, readout_format=".4g")

    def on_level(change) -> None:
        """The slider moved: put its value on the selected level and draw again."""
        viewer.state.iso = change["new"]
        canvas.request_draw()
    slider.observe(on_level, names="value")
    box = ipywidgets.VBox([canvas, slider])
    box.canvas, box.slider, box.viewer = canvas, slider, viewer
    box.close_viewer = viewer.release
    return box


def _needed(module: str):
    """The optional module `module`, or MissingPackage naming it (not both packages, when one is there)."""
    import importlib
    try:
        return importlib.import_module(module)
    except ImportError:
        from ..errors import MissingPackage
        package = module.replace("_", "-")
        raise MissingPackage(f"isoscope.widget needs {package}, which is not installed here: pip install {package} "
                             '(or pip install "isoscope[notebook]" for everything the widget uses)') from None
