"""An orbit camera around the volume: azimuth/elevation/distance about a target point.

The scene is the extractor's: array index x spacing, array axis 0 is x, axis 2 is z.  The camera
orbits in a *display frame*: the scene itself (z up) for a volume without a patient frame, and the
patient's LPS frame (x left, y posterior, z superior) for a scan whose file says how its array lies
in the patient (NIfTI, NRRD, DICOM: `Volume.world`).  `fit(frame=...)` takes that scene -> display
rotation (`anatomical_frame`), so a head opens superior up however its slices were stored; where the
storage order is a mirror image of the patient (every DICOM series: slice, row, column is
left-handed in LPS), the frame is a reflection, the view matrix mirrors the scene back, and
`mirrored` tells the renderer to swap its front faces.

Azimuth and elevation are the eye's direction in the display frame: azimuth about its z axis from
+x, elevation above its x-y plane.  A scan opens from anterior (azimuth -90, elevation 0), superior
up, as 3D Slicer's 3-D view does; other volumes keep the oblique (-60, 25).  `VIEWS` are the six
standard directions, the same angles in both frames (key 1 looks from anterior, or from -y).
Matrices come from pyrr, whose row-vector layout is what a GLSL mat4 uniform
expects when written with `.astype("f4").tobytes()`.
"""
from __future__ import annotations

import math

import numpy as np
from pyrr import matrix44

from ...volumes.volume import ANATOMICAL_SPACES

WORLD_UP = np.array([0.0, 0.0, 1.0])
HOME_AZIMUTH = -60.0     # degrees; an oblique view shows all three axes
HOME_ELEVATION = 25.0
ANATOMICAL_HOME = (-90.0, 0.0)   # from anterior, superior up: 3D Slicer's default 3-D view
ORBIT_LIMIT = 89.0       # a drag stops short of the poles; a view from above or below sits on them
RAS_TO_LPS = np.diag([-1.0, -1.0, 1.0])

# The six standard views: (azimuth, elevation) in the display frame, and the eye's side in its words.
# Superior and inferior put anterior at the top of the screen, as Slicer's and radiology's axial views.
VIEWS = (
    ("anterior", "-y", (-90.0, 0.0)),
    ("posterior", "+y", (90.0, 0.0)),
    ("left", "+x", (0.0, 0.0)),
    ("right", "-x", (180.0, 0.0)),
    ("superior", "+z", (90.0, 90.0)),
    ("inferior", "-z", (-90.0, -90.0)),
)


def anatomical_frame(world) -> np.ndarray | None:
    """The rotation (or, for a left-handed storage order, rotation and mirror) taking a scene direction
    to the patient's LPS frame, for `world` = (4x4 array index -> world, "RAS" or "LPS") as `Volume.world`
    holds it; None without one, or for a frame that places nothing in a patient (an OME-Zarr image's).  The
    nearest orthogonal matrix to the transform's unit axes (its polar factor), so the voxel sizes and a slight
    shear drop out."""
    if world is None or world[1] not in ANATOMICAL_SPACES:
        return None
    matrix, space = world
    axes = np.asarray(matrix, float)[:3, :3]
    axes = axes / np.linalg.norm(axes, axis=0)
    u, _, vt = np.linalg.svd(axes)
    frame = u @ vt
    return RAS_TO_LPS @ frame if space == "RAS" else frame


def volume_frame(volume) -> np.ndarray | None:
    """`anatomical_frame` of a Volume (None for none, or one without a patient frame)."""
    return None if volume is None else anatomical_frame(getattr(volume, "world", None))
ORBIT_DEGREES_PER_PIXEL = 0.4
ZOOM_PER_STEP = 0.9      # distance factor per scroll notch


class OrbitCamera:
    """The view of the 3-D scene: azimuth, elevation and distance about a target point, in the scene's own frame or a
    scan's patient frame; `fit` frames a box, `orbit`, `pan` and `zoom` follow the pointer, and `view_matrix` /
    `projection_matrix` hand the result to GL."""

    def __init__(self, fov_degrees: float = 35.0):
        self.fov_degrees = fov_degrees
        self.frame: np.ndarray | None = None   # scene -> display frame (3x3 orthogonal); None: the scene's own
        self.fit((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))

    # --- framing -----------------------------------------------------------
    def fit(self, lower, upper, azimuth: float | None = None, elevation: float | None = None,
            frame: np.ndarray | None = None) -> None:
        """Frame the box [lower, upper] (scene units): centre it and back off until its bounding sphere fits.
        `frame`: the scene -> patient (LPS) rotation of a scan (`anatomical_frame`), which the camera then
        orbits in, superior up, from anterior unless `azimuth` / `elevation` say otherwise."""
        lower, upper = np.asarray(lower, float), np.asarray(upper, float)
        self.frame = None if frame is None else np.asarray(frame, float).reshape(3, 3)
        home_azimuth, home_elevation = (HOME_AZIMUTH, HOME_ELEVATION) if frame is None else ANATOMICAL_HOME
        self.target = (lower + upper) / 2
        self.scene_radius = max(float(np.linalg.norm(upper - lower)) / 2, 1e-6)
        self.azimuth = home_azimuth if azimuth is None else float(azimuth)
        self.elevation = home_elevation if elevation is None else float(np.clip(elevation, -90.0, 90.0))
        self.distance = self._fit_distance()
        self._home = (self.target.copy(), self.azimuth, self.elevation, self.distance)

    def look_from(self, azimuth: float, elevation: float) -> None:
        """Turn to look from (azimuth, elevation) of the display frame (`VIEWS`), keeping target and zoom."""
        self.azimuth = float(azimuth) % 360.0
        self.elevation = float(np.clip(elevation, -90.0, 90.0))

    @property
    def mirrored(self) -> bool:
        """Whether the view mirrors the scene (a left-handed storage order shown the patient's way round):
        the renderer then takes clockwise triangles as front faces."""
        return self.frame is not None and float(np.linalg.det(self.frame)) < 0

    def reset(self) -> None:
        """Back to the view `fit` chose (key `r`)."""
        target, self.azimuth, self.elevation, self.distance = self._home
        self.target = target.copy()

    def _fit_distance(self) -> float:
        # The sphere fits the vertical field of view; a small margin keeps it off the edges.
        return 1.1 * self.scene_radius / math.sin(math.radians(self.fov_degrees) / 2)

    # --- mouse -------------------------------------------------------------
    def orbit(self, dx_pixels: float, dy_pixels: float) -> None:
        """Turn about the target by a pointer drag of (`dx_pixels`, `dy_pixels`); the elevation stops short of the poles
        (or stays on one it started from), where a fixed up vector would flip the view."""
        self.azimuth = (self.azimuth - dx_pixels * ORBIT_DEGREES_PER_PIXEL) % 360.0
        # Stop short of the poles, where look-at with a fixed up vector flips (a view from above or
        # below, on a pole, stays there rather than jumping a degree).
        limit = max(ORBIT_LIMIT, abs(self.elevation))
        self.elevation = float(np.clip(self.elevation + dy_pixels * ORBIT_DEGREES_PER_PIXEL, -limit, limit))

    def zoom(self, steps: float) -> None:
        """Positive steps move closer (scroll up)."""
        self.distance = float(np.clip(self.distance * ZOOM_PER_STEP ** steps,
                                      self.scene_radius * 0.05, self.scene_radius * 50))

    def pan(self, dx_pixels: float, dy_pixels: float, viewport_height: int) -> None:
        """Move the target in the view plane so the point under the cursor follows it."""
        world_per_pixel = 2 * self.distance * math.tan(math.radians(self.fov_degrees) / 2) / max(viewport_height, 1)
        right, up = self.screen_axes()
        self.target = self.target + (-dx_pixels * right + dy_pixels * up) * world_per_pixel

    def screen_axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit vectors (scene space) pointing to the screen's right and up."""
        if self._plain():
            forward = self.target - self.eye()
            forward /= np.linalg.norm(forward)
            right = np.cross(forward, WORLD_UP)
            right /= np.linalg.norm(right)
            return right, np.cross(right, forward)
        right, up = self._display_axes()
        frame = self._frame()
        return frame.T @ right, frame.T @ up   # display -> scene: the frame is orthogonal

    # --- matrices ----------------------------------------------------------
    def _plain(self) -> bool:
        """No display frame and off the poles: today's look-at about the scene's z, bit for bit."""
        return self.frame is None and abs(self.elevation) <= ORBIT_LIMIT

    def _frame(self) -> np.ndarray:
        return np.eye(3) if self.frame is None else self.frame

    def _direction(self) -> np.ndarray:
        """The eye's direction from the target, in the display frame."""
        azimuth, elevation = math.radians(self.azimuth), math.radians(self.elevation)
        return np.array([math.cos(elevation) * math.cos(azimuth),
                         math.cos(elevation) * math.sin(azimuth),
                         math.sin(elevation)])

    def _display_axes(self) -> tuple[np.ndarray, np.ndarray]:
        """The screen's right and up in the display frame, from the angles alone: defined on the poles
        too, where the right is where azimuth puts it and the up follows (a view from above with
        azimuth 90 has -y, anterior, at the top)."""
        azimuth = math.radians(self.azimuth)
        right = np.array([-math.sin(azimuth), math.cos(azimuth), 0.0])
        return right, np.cross(self._direction(), right)

    def eye(self) -> np.ndarray:
        """The camera's position in scene units: `distance` from the target along the current direction, turned into the
        scene from the display frame."""
        direction = self._direction()
        return self.target + self.distance * (direction if self.frame is None else self.frame.T @ direction)

    def view_matrix(self) -> np.ndarray:
        """The 4x4 world -> eye matrix (float32, pyrr's row-vector layout) looking at the target; with a patient frame
        the scene is turned into it first (a mirrored frame makes the whole view a mirror)."""
        if self._plain():
            return matrix44.create_look_at(self.eye(), self.target, WORLD_UP, dtype="f4")
        # Look at the target in the display frame, after taking the scene there: p -> frame @ p, which
        # pyrr's row vectors write p @ frame.T.  A mirror frame makes the whole view a mirror.
        frame = self._frame()
        target = frame @ self.target
        look = matrix44.create_look_at(target + self.distance * self._direction(), target,
                                       self._display_axes()[1])
        to_display = np.eye(4)
        to_display[:3, :3] = frame.T
        return (to_display @ look).astype("f4")

    def projection_matrix(self, aspect: float, shift_x: float = 0.0) -> np.ndarray:
        """Perspective for a viewport of `aspect` (width/height); `shift_x` moves the image
        centre right by that much NDC (a lens shift), to centre the scene beside the panel."""
        # Near/far hug the scene's bounding sphere: depth precision where the surface is.
        near = max(self.distance - 1.5 * self.scene_radius, self.distance * 0.01)
        far = self.distance + 1.5 * self.scene_radius
        projection = matrix44.create_perspective_projection(self.fov_degrees, max(aspect, 1e-6), near, far, dtype="f4")
        if shift_x:
            # pyrr composes left to right: project first, then translate in clip space.
            shift = matrix44.create_from_translation([shift_x, 0.0, 0.0], dtype="f4")
            projection = matrix44.multiply(projection, shift)
        return projection
