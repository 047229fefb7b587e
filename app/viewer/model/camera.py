"""An orbit camera around the volume: azimuth/elevation/distance about a target point.

World space is the extractor's: array axis 0 is x, axis 2 is z, and z is up.
Matrices come from pyrr, whose row-vector layout is what a GLSL mat4 uniform
expects when written with `.astype("f4").tobytes()`.
"""
from __future__ import annotations

import math

import numpy as np
from pyrr import matrix44

WORLD_UP = np.array([0.0, 0.0, 1.0])
HOME_AZIMUTH = -60.0     # degrees; an oblique view shows all three axes
HOME_ELEVATION = 25.0
ORBIT_DEGREES_PER_PIXEL = 0.4
ZOOM_PER_STEP = 0.9      # distance factor per scroll notch


class OrbitCamera:
    def __init__(self, fov_degrees: float = 35.0):
        self.fov_degrees = fov_degrees
        self.fit((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))

    # --- framing -----------------------------------------------------------
    def fit(self, lower, upper, azimuth: float | None = None, elevation: float | None = None) -> None:
        """Frame the box [lower, upper] (world units): centre it and back off until its bounding sphere fits."""
        lower, upper = np.asarray(lower, float), np.asarray(upper, float)
        self.target = (lower + upper) / 2
        self.scene_radius = max(float(np.linalg.norm(upper - lower)) / 2, 1e-6)
        self.azimuth = HOME_AZIMUTH if azimuth is None else float(azimuth)
        self.elevation = HOME_ELEVATION if elevation is None else float(np.clip(elevation, -89.0, 89.0))
        self.distance = self._fit_distance()
        self._home = (self.target.copy(), self.azimuth, self.elevation, self.distance)

    def reset(self) -> None:
        """Back to the view `fit` chose (key `r`)."""
        target, self.azimuth, self.elevation, self.distance = self._home
        self.target = target.copy()

    def _fit_distance(self) -> float:
        # The sphere fits the vertical field of view; a small margin keeps it off the edges.
        return 1.1 * self.scene_radius / math.sin(math.radians(self.fov_degrees) / 2)

    # --- mouse -------------------------------------------------------------
    def orbit(self, dx_pixels: float, dy_pixels: float) -> None:
        self.azimuth = (self.azimuth - dx_pixels * ORBIT_DEGREES_PER_PIXEL) % 360.0
        # Stop short of the poles, where look-at with a fixed up vector flips.
        self.elevation = float(np.clip(self.elevation + dy_pixels * ORBIT_DEGREES_PER_PIXEL, -89.0, 89.0))

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
        forward = self.target - self.eye()
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, WORLD_UP)
        right /= np.linalg.norm(right)
        return right, np.cross(right, forward)

    # --- matrices ----------------------------------------------------------
    def eye(self) -> np.ndarray:
        azimuth, elevation = math.radians(self.azimuth), math.radians(self.elevation)
        direction = np.array([math.cos(elevation) * math.cos(azimuth),
                              math.cos(elevation) * math.sin(azimuth),
                              math.sin(elevation)])
        return self.target + self.distance * direction

    def view_matrix(self) -> np.ndarray:
        return matrix44.create_look_at(self.eye(), self.target, WORLD_UP, dtype="f4")

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
