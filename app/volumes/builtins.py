"""The generated volumes: `isoscope volumes` lists them, any VOLUME argument accepts them.

Each is a function of (x, y, z) over a box, sampled at a resolution the user
may choose ("sphere:128"). Each declares which side is inside (its gradient
direction) and a level at which it shows the intended surface, so normals
point out of the object and the first frame looks right.
"""
from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .grid import LOWER_RESOLUTION, Box, pick_resolution, sample_function
from .volume import Progress, Volume, finish_volume, refuse_if_too_big, report

UNIT_BOX = Box.cube(-1.0, 1.0)


@dataclass(frozen=True)
class Builtin:
    """A built-in volume: its name and description, how to make it at a resolution, its object side and first level (and
    a fixed shape for one whose resolution cannot change)."""
    name: str
    description: str
    default_resolution: int
    gradient_direction: str
    default_level: float
    make: Callable[[int, Progress | None], tuple[np.ndarray, tuple[float, float, float], list[str]]]
    fixed_shape: tuple[int, int, int] | None = None  # set when the resolution cannot change

    @property
    def summary(self) -> str:
        """The line `isoscope volumes` prints."""
        size = "x".join(map(str, self.fixed_shape)) if self.fixed_shape else f"default {self.default_resolution}^3"
        return f"{self.description} [{size}]"


def _on_unit_box(field, what):
    """A maker sampling field(x, y, z) on [-1, 1]^3 at n samples per axis, as float32."""
    def make(n, progress):
        shape = (n, n, n)
        return sample_function(field, UNIT_BOX, shape, what=what, progress=progress), \
            UNIT_BOX.spacing(shape), []
    return make


# --- signed distance fields: negative inside, so "ascent" ------------------------------

def _sphere(x, y, z):
    return np.sqrt(x * x + y * y + z * z) - 0.7


def _torus(x, y, z):
    ring, tube = 0.6, 0.25
    return np.sqrt((np.sqrt(x * x + y * y) - ring) ** 2 + z * z) - tube


def _box(x, y, z):
    # Exact box SDF (Quilez): its edges and corners are sharp features that plain
    # marching cubes rounds off, which is what this volume is here to show.
    half = (0.6, 0.45, 0.3)
    qx, qy, qz = np.abs(x) - half[0], np.abs(y) - half[1], np.abs(z) - half[2]
    outside = np.sqrt(np.maximum(qx, 0) ** 2 + np.maximum(qy, 0) ** 2 + np.maximum(qz, 0) ** 2)
    inside = np.minimum(np.maximum(qx, np.maximum(qy, qz)), 0)
    return outside + inside


def _plane(x, y, z):
    # The implicit plane x + 2y - 3z + 1 = 0 (Foley et al., Computer Graphics: Principles and Practice);
    # "inside" is the negative half-space.
    return x + 2 * y - 3 * z + 1


GYROID_BOX = Box.cube(-2 * np.pi, 2 * np.pi)  # two periods per axis


def _make_gyroid(n, progress):
    def gyroid(x, y, z):
        return np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x)
    shape = (n, n, n)
    return sample_function(gyroid, GYROID_BOX, shape, what="gyroid", progress=progress), \
        GYROID_BOX.spacing(shape), []


# --- Soft objects (Wyvill, McPheeters and Wyvill 1986, the first marching cubes): density, "descent" ------------------

METABALL_CENTRES = 1.15 * np.array([
    (0.0, 0.0, 0.0), (0.42, 0.1, 0.05), (-0.4, 0.15, -0.1), (0.05, 0.45, 0.15),
    (0.1, -0.42, -0.05), (-0.15, -0.2, 0.4), (0.2, 0.15, -0.42), (-0.5, -0.4, 0.2),
    (0.55, -0.35, 0.35), (-0.2, 0.55, -0.4),
])
METABALL_RADIUS = 0.56  # radius of influence R; a lone ball's 0.5-level surface has radius R/2


def _metaballs(x, y, z):
    total = 0.0
    for cx, cy, cz in METABALL_CENTRES:
        s = np.minimum(((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / METABALL_RADIUS ** 2, 1.0)
        # C(r) = 1 - 22/9 s + 17/9 s^2 - 4/9 s^3 with s = r^2/R^2; exactly 0 at r >= R.
        total = total + np.maximum(1 + s * (-22 / 9 + s * (17 / 9 - 4 / 9 * s)), 0.0)
    return total


# --- C60 like the CUDA sample's Bucky.raw: uint8 density, "descent" ---------------------

def c60_atoms() -> np.ndarray:
    """The 60 vertices of a truncated icosahedron, edge length 2 (circumradius ~4.956).

    Cyclic permutations with all sign flips of (0, 1, 3phi), (2, 1+2phi, phi), (1, 2+phi, 2phi).
    """
    phi = (1 + 5 ** 0.5) / 2
    atoms = set()
    for base in ((0, 1, 3 * phi), (2, 1 + 2 * phi, phi), (1, 2 + phi, 2 * phi)):
        for shift in range(3):
            rotated = base[shift:] + base[:shift]
            for signs in itertools.product((1, -1), repeat=3):
                atoms.add(tuple(round(s * c, 9) for s, c in zip(signs, rotated)))
    return np.array(sorted(atoms))


BUCKY_SIGMA = 0.085
_BUCKY_CUTOFF = 5 * BUCKY_SIGMA  # exp(-12.5) * 255 < 0.001: beyond it an atom adds nothing to a uint8


def _make_bucky(n, progress):
    atoms = c60_atoms() * (0.75 / 4.956)  # circumradius 0.75: fits the unit box with a margin
    shape = (n, n, n)
    refuse_if_too_big(shape, 4, "bucky", fix=LOWER_RESOLUTION)
    axis = UNIT_BOX.axis(0, n)
    density = np.zeros(shape, dtype=np.float32)
    # Each atom touches only the samples within its cutoff: ~40x less work than summing
    # 60 Gaussians over the whole grid, which makes bucky:256 take a moment, not seconds.
    for done, atom in enumerate(atoms, start=1):
        window = []
        for a in range(3):
            first, last = np.searchsorted(axis, (atom[a] - _BUCKY_CUTOFF, atom[a] + _BUCKY_CUTOFF))
            window.append(slice(first, last))
        x, y, z = (axis[window[a]].reshape([-1 if b == a else 1 for b in range(3)]) - atom[a] for a in range(3))
        density[tuple(window)] += np.exp(-(x * x + y * y + z * z) / (2 * BUCKY_SIGMA ** 2))
        report(progress, done / len(atoms), "computing bucky")
    data = np.clip(np.rint(255 * density), 0, 255).astype(np.uint8)
    return data, UNIT_BOX.spacing(shape), []


# --- every marching-cubes case, the ambiguous ones included -----------------------------

AMBIGUOUS_SHAPE = (25, 25, 13)  # 8 x 8 x 4 cells at a stride of 3 samples, plus a border


def _make_ambiguous(n, progress):
    """The cell whose low corner is sample (3a+1, 3b+1, 3c+1) has sign pattern a + 8b + 64c.

    Pattern p puts corner (dx, dy, dz) inside when bit dx + 2dy + 4dz of p is set,
    so the 8 x 8 x 4 cells hold all 256 marching-cubes cases.
    Corner magnitudes vary (a fixed random draw), so the ambiguous faces' saddle
    values fall on both sides of 0 and the asymptotic decider has real work.
    Samples between the cells are outside, so each case is its own small piece.
    """
    rng = np.random.default_rng(256)
    data = np.full(AMBIGUOUS_SHAPE, -1.0, dtype=np.float32)
    for pattern in range(256):
        a, b, c = pattern % 8, (pattern // 8) % 8, pattern // 64
        for dx, dy, dz in itertools.product((0, 1), repeat=3):
            inside = (pattern >> (dx + 2 * dy + 4 * dz)) & 1
            magnitude = rng.uniform(0.2, 1.0)
            data[3 * a + 1 + dx, 3 * b + 1 + dy, 3 * c + 1 + dz] = magnitude if inside else -magnitude
    notes = [] if n == AMBIGUOUS_SHAPE[0] else [
        f"ambiguous is a fixed {'x'.join(map(str, AMBIGUOUS_SHAPE))} grid; the resolution is ignored"]
    return data, (1.0, 1.0, 1.0), notes


BUILTINS: dict[str, Builtin] = {b.name: b for b in (
    Builtin("sphere", "signed distance to a sphere of radius 0.7 (negative inside)", 64,
            "ascent", 0.0, _on_unit_box(_sphere, "sphere")),
    Builtin("torus", "signed distance to a torus, ring 0.6, tube 0.25", 64,
            "ascent", 0.0, _on_unit_box(_torus, "torus")),
    Builtin("plane", "the plane x + 2y - 3z + 1 = 0 over [-1, 1]^3, with samples exactly on it", 32,
            "ascent", 0.0, _on_unit_box(_plane, "plane")),
    Builtin("gyroid", "sin x cos y + sin y cos z + sin z cos x, two periods per axis", 96,
            "ascent", 0.0, _make_gyroid),
    Builtin("metaballs", "ten Wyvill soft objects (density, level 0.5)", 80,
            "descent", 0.5, _on_unit_box(_metaballs, "metaballs")),
    Builtin("bucky", "C60: 60 atoms on a truncated icosahedron, uint8 like the CUDA sample's Bucky.raw", 64,
            "descent", 128.0, _make_bucky),
    Builtin("box", "signed distance to a box: sharp edges and corners", 64,
            "ascent", 0.0, _on_unit_box(_box, "box")),
    Builtin("ambiguous", "all 256 cube sign patterns, one per cell, ambiguous faces both ways",
            AMBIGUOUS_SHAPE[0], "descent", 0.0, _make_ambiguous, fixed_shape=AMBIGUOUS_SHAPE),
)}


def split_builtin_spec(spec: str) -> tuple[Builtin, str | None] | None:
    """'sphere' or 'sphere:128' -> (the builtin, '128'); None when the name is not a builtin."""
    name, _, resolution = spec.partition(":")
    builtin = BUILTINS.get(name.strip().lower())
    if builtin is None:
        return None
    return builtin, (resolution.strip() or None) if _ else None


def open_builtin(spec: str, resolution=None, progress: Progress | None = None) -> Volume:
    """The built-in volume `spec` (``name`` or ``name:N``, a name `split_builtin_spec` knows) made at its resolution
    (`resolution`, the spec's, else its default); a resolution that is no whole number, out of range or given twice
    is a VolumeError."""
    builtin, spec_resolution = split_builtin_spec(spec)
    n = pick_resolution(spec_resolution, resolution, builtin.default_resolution, builtin.name)
    data, spacing, notes = builtin.make(n, progress)
    report(progress, 1.0, f"{builtin.name} ready")
    name = builtin.name if n == builtin.default_resolution else f"{builtin.name}:{n}"
    return finish_volume(data, spacing=spacing, name=name, source=spec, gradient_direction=builtin.gradient_direction,
                         default_level=builtin.default_level, notes=notes)
