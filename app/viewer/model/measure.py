"""The panel's Measure section without GL: each surface's area, enclosed volume, pieces and bounding box,
measured on request in the background, and the cursor probe's picked points and their distance.

`Measurements.request(state)` takes what is on show (the volume, its levels or visible labels, the mesh
options) and measures it on a worker thread with the code `isoscope measure` runs: the same CPU extraction
(cubes, or the viewer's tetrahedra and smoothing), `in_volume_space` (world millimetres where the file has
a frame), `cpu.measure.measure_surface`, `in_millimetres` (a file in micrometres, ...); so a plain level gives
the command's numbers.  It is a request
with an id and a response (jobs.py): a newer request makes an older one stale, and `poll` (once a frame)
keeps the newest answer, or its error.  A big volume is measured as shown (every `step`-th sample) and
says so.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...one_shot import closed_mesh, extraction_of
from .errors import ViewerError, one_line
from .jobs import Jobs

ML_PER_MM3 = 1e-3
MAX_PICKS = 2   # a distance is between two points


@dataclass(frozen=True)
class SurfaceRecord:
    """One surface's measures, in the keys and units of `isoscope measure --json`."""
    name: str                         # "level 127.5" or "label 3"
    area_mm2: float
    volume_ml: float
    components: int
    largest_component_ml: float
    bbox_min: tuple[float, float, float] | None
    bbox_max: tuple[float, float, float] | None
    open_edges: int
    euler: int = 0
    genus: int | None = None          # the handles of a closed surface; None where it is open
    cavities: int = 0                 # pieces enclosing less than nothing: a hollow's inner walls
    cavities_ml: float = 0.0          # what they take away (>= 0)

    @property
    def size(self) -> tuple[float, float, float] | None:
        """The bounding box's extent along each axis (world units), or None for a surface with no finite vertex."""
        if self.bbox_min is None:
            return None
        return tuple(hi - lo for lo, hi in zip(self.bbox_min, self.bbox_max))


@dataclass(frozen=True)
class MeasureRequest:
    """What to measure: plain data, so the worker thread shares nothing that the panel changes."""
    volume: object                    # the Volume on show
    levels: tuple[float, ...]         # the levels' values (empty with labels)
    labels: tuple[int, ...]           # the visible labels (empty without a label map)
    cells: str = "cubes"
    smooth: int = 0
    closed: bool = False
    step: int = 1                     # the volume on show is every `step`-th sample of the file
    topology: str = "montani"


def record_of(name: str, verts, faces, mm_per_unit: float = 1.0) -> SurfaceRecord:
    """The Measure section's row for one surface (`name`) from its mesh: area, enclosed volume and the largest part's in
    millilitres (from cubic millimetres), components, bounding box, open edges, Euler characteristic, genus and
    cavities.  `mm_per_unit`: millimetres per unit of the mesh's lengths (the file's stated unit, core.units), by
    which they are converted as `isoscope measure` converts them."""
    from ...cpu.measure import in_millimetres, measure_surface
    m = in_millimetres(measure_surface(verts, faces), mm_per_unit)
    finite = all(math.isfinite(v) for v in m.bbox_min)
    return SurfaceRecord(name, m.area, m.volume * ML_PER_MM3, m.components, m.largest_component_volume * ML_PER_MM3,
                         tuple(m.bbox_min) if finite else None, tuple(m.bbox_max) if finite else None, m.open_edges,
                         m.euler, m.genus, m.cavities, -m.cavity_volume * ML_PER_MM3)


def level_mesh(volume, level: float, cells: str = "cubes", smooth: int = 0, closed: bool = False,
               topology: str = "montani"):
    """(verts, faces) of `volume` at `level` in world space, extracted on the CPU as `isoscope measure`
    and `export` do (`closed`: capped where the surface leaves the volume, as export --closed)."""
    from ...io.export import in_volume_space
    from ...validation import as_level
    if closed:
        verts, faces, normals, _ = closed_mesh(volume, level, cells, smooth, topology)
    else:
        verts, faces, normals, _ = extraction_of(cells, topology)(volume.checked, as_level(level, volume.value_range),
                                                    spacing=volume.spacing, backend="cpu",
                                                    gradient_direction=volume.gradient_direction, smooth=smooth)
    verts, faces, _, _ = in_volume_space(volume, verts, faces, normals)
    return verts, faces


def measure(request: MeasureRequest, progress=None) -> list[SurfaceRecord]:
    """The records of `request`'s surfaces (the work of a "measure" job)."""
    from ...core.units import mm_per_unit
    volume, records = request.volume, []
    factor = mm_per_unit(getattr(volume, "length_unit", None))   # the file's micrometres, ... in millimetres
    if request.labels:
        from ...io.export import in_volume_space
        from ...labels import label_surfaces, labels_of
        labels = labels_of(volume)
        wanted = np.isin(labels, request.labels)
        surfaces = label_surfaces(np.where(wanted, labels, 0), spacing=volume.spacing, backend="cpu")
        for label, mesh in surfaces.items():
            verts, faces, _, _ = in_volume_space(volume, *mesh)
            records.append(record_of(f"label {int(label)}", verts, faces, factor))
        return records
    for i, level in enumerate(request.levels):
        if progress is not None:
            progress(i / len(request.levels), f"measuring level {level:.5g}")
        verts, faces = level_mesh(volume, level, request.cells, request.smooth, request.closed, request.topology)
        records.append(record_of(f"level {level:.5g}", verts, faces, factor))
    return records


class Measurements:
    """The Measure section's model: the last answer (`records`), the one being made (`running`), and the
    cursor probe's picks (`picks`, world points) with their `distance`."""

    def __init__(self):
        self.jobs = Jobs()
        self.records: list[SurfaceRecord] = []
        self.note: str | None = None        # e.g. "measured at 1/2 resolution"
        self.error: str | None = None
        self.request_id: int | None = None  # the newest request
        self.answered_id: int | None = None  # the request `records` answer
        self.picks: list[np.ndarray] = []   # in the file's frame (mm): distances are taken here
        self.points: list[np.ndarray | None] = []   # the same points in scene coordinates, to mark them
        self.probe = None                   # the last probe (picking.Probe), for the panel
        self.mm_per_unit = 1.0              # millimetres per unit of the picks' frame (the file's stated unit)

    def request_of(self, state) -> MeasureRequest:
        """What to measure in `state` now: its visible labels, else its visible levels, with the mesh options and step
        on show. ViewerError when no volume is open or nothing is visible."""
        if state.volume is None:
            raise ViewerError("open a volume before measuring")
        labels = tuple(layer.label for layer in state.labels.visible()) if state.labels else ()
        if state.labels and not labels:
            raise ViewerError("no label is visible; tick the labels to measure")
        levels = () if labels else tuple(float(level.value) for level in state.levels if level.visible)
        if not labels and not levels:
            raise ViewerError("no surface is visible; show a level to measure it")
        options = state.mesh_options
        return MeasureRequest(state.volume, levels, labels, options.cells, options.smooth, state.closed, state.step,
                              options.topology)

    def request(self, state, inline: bool = False) -> int:
        """Measure what `state` shows, in the background (`inline`: here, for tests and scripts); the
        request's id.  What cannot be measured raises its one line."""
        request = self.request_of(state)
        self.request_id = self.jobs.submit("measure", _measured, request, inline=inline,
                                           message="measuring", failure="measuring failed")
        return self.request_id

    @property
    def running(self):
        """The job being measured (its `fraction`, `message`), or None."""
        return self.jobs.current("measure")

    def poll(self, wait_s: float = 0.0) -> bool:
        """Take the newest answer if it came; whether one did."""
        came = False
        for response in self.jobs.poll(wait_s):
            came = True
            self.answered_id = response.request_id
            if response.error is not None:
                self.error, self.records, self.note = one_line(response.error), [], None
            else:
                self.error = None
                self.records, self.note = response.value
        return came

    # --- the cursor probe's two-point distance ---------------------------------
    def pick(self, world, point=None, mm_per_unit: float = 1.0) -> None:
        """Add a point (`world`: the file's frame; `point`: scene coordinates, to mark it; `mm_per_unit`:
        millimetres per unit of that frame, core.units.mm_per_unit of the volume's length unit); a third starts
        a new pair."""
        if len(self.picks) >= MAX_PICKS:
            self.clear_picks()
        self.mm_per_unit = float(mm_per_unit)
        self.picks.append(np.asarray(world, np.float64).reshape(3))
        self.points.append(None if point is None else np.asarray(point, np.float64).reshape(3))

    def clear_picks(self) -> None:
        """Forget the cursor probe's picks and their points (the distance goes with them)."""
        self.picks, self.points = [], []

    @property
    def distance(self) -> float | None:
        """The distance (mm: the file's units converted) between the two picked points, or None before two."""
        if len(self.picks) < MAX_PICKS:
            return None
        return float(np.linalg.norm(self.picks[1] - self.picks[0])) * self.mm_per_unit


def _measured(request: MeasureRequest, progress=None):
    from ...core.units import mm_per_unit
    records = measure(request, progress)
    notes = [f"measured as shown: every {request.step}th sample (the file is larger)"] if request.step > 1 else []
    unit = getattr(request.volume, "length_unit", None)
    if mm_per_unit(unit) != 1.0:   # as `isoscope measure` says it once
        notes.append(f"the file's lengths are in {unit}: converted to mm, mm^2 and mL")
    return records, "; ".join(notes) or None
