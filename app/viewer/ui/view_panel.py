"""The panel's View section: the six standard view directions.

A scan with a patient frame (NIfTI, NRRD, DICOM) gets anterior, posterior, left, right, superior and
inferior, superior up (anterior up from above and below), as 3D Slicer's view buttons; a volume without
one gets the same six turns along its array axes, named by the side the eye is on (-y, +y, +x, ...).
Keys 1-6 do the same in the window.  Plugged into `Panel.draw` (panel.py); its keys reach the window
through `keys()`."""
from __future__ import annotations

from ..model.camera import VIEWS, volume_frame
from ..model.state import ViewerState
from .gui import imgui, section, tooltip

VIEW_KEYS = "123456"   # in VIEWS' order; free in the window's key table (window.py `_on_char`)
ANATOMICAL_BUTTONS = ("A", "P", "L", "R", "S", "I")


def view_names(volume) -> list[tuple[str, str]]:
    """(button label, what it shows) for each of the six views of `volume`: anatomical where its file
    places it in the patient, else the array axis the eye sits on."""
    if volume_frame(volume) is not None:   # a patient frame (not an OME-Zarr image's scale and translation)
        return [(button, f"from {name}") for button, (name, _, _) in zip(ANATOMICAL_BUTTONS, VIEWS)]
    return [(axis, f"from {axis} (array axes: no patient frame in this file)") for _, axis, _ in VIEWS]


class ViewSection:
    """The panel's View section: six buttons that look from the standard directions."""

    def __init__(self):
        self.button_boxes: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {}   # key -> rect

    def draw(self, state: ViewerState, camera) -> None:
        """A row of six buttons that turn the camera to look from each standard direction."""
        if not section("View") or camera is None or state.volume is None:
            return
        for i, ((label, what), key, (_, _, angles)) in enumerate(zip(view_names(state.volume), VIEW_KEYS, VIEWS)):
            if i:
                imgui.same_line()
            if imgui.button(f"{label}##view{key}", imgui.ImVec2(36, 0)):
                camera.look_from(*angles)
            self.button_boxes[key] = (tuple(imgui.get_item_rect_min()), tuple(imgui.get_item_rect_max()))
            tooltip(f"view {what} (key {key})")

    def keys(self, camera) -> dict:
        """Characters this section answers in the window (as window.py's `_on_char` table): 1-6, the views."""
        return {key: (lambda angles=angles: camera.look_from(*angles)) for key, (_, _, angles) in zip(VIEW_KEYS, VIEWS)}
