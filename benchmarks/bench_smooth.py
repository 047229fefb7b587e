#!/usr/bin/env python3
"""Benchmark smoothing projected onto the level set (issue 9) against plain MC and VTK's smoothing.

One process, one run, so the ratios are measured under the same load.  For each volume of
benchmarks/volumes.py at each size, as medians of --repeats:

- MC iso change: a resident `Extractor` alternating between two nearby levels (as bench_extract.py);
- smoothing added: `Smoother.smooth(mesh, N)` right after such an extraction (neighbour list built,
  N iterations, normals; returns when the GPU is done), and its ratio to the MC iso change;
- VTK: `vtkWindowedSincPolyDataFilter` (N iterations, its defaults otherwise: pass band 0.1,
  no projection) on the same MC mesh, already in a vtkPolyData; only Update() is timed.

Quality, on every mesh (plain MC, ours, VTK's): how far vertices lie off the level set, in
voxels (|F - level| / |grad F|, F trilinear, on up to 20,000 vertices), and off a smooth
interpolant's level set (F the cubic B-spline through the samples, scipy's map_coordinates of
order 3): ours aims at the latter, correcting the trilinear interpolant's error (see
app/reference_smooth.py); and the histogram of each triangle's smallest angle (on up to a
million triangles, evenly picked).
Prints markdown; see benchmarks/README.md.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from scipy.ndimage import map_coordinates, spline_filter

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import isoscope  # noqa: E402
from isoscope.core.interpolate import trilinear  # noqa: E402
from isoscope.gpu.cubes import Extractor  # noqa: E402
from isoscope.gpu.smooth import Smoother  # noqa: E402

from volumes import VOLUMES  # noqa: E402

LEVEL_STEP = 0.005  # the second level: 0 + 0.5% of the range, as bench_extract.py
ANGLE_BINS = (0, 5, 10, 20, 30, 40, 50, 60.01)


def log(*parts) -> None:
    print(*parts, file=sys.stderr, flush=True)


def median_ms(run, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append((time.perf_counter() - start) * 1000)
    return statistics.median(times)


def smallest_angles(verts, faces) -> np.ndarray:
    corners = verts[faces].astype(np.float64)
    angles = []
    for i in range(3):
        a, b = corners[:, (i + 1) % 3] - corners[:, i], corners[:, (i + 2) % 3] - corners[:, i]
        cos = np.sum(a * b, axis=1) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-30)
        angles.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.min(angles, axis=0)


def off_level_voxels(volume, verts, level, spline=None, samples=20000) -> np.ndarray:
    """|F - level| / |grad F| at up to `samples` vertices (array-index units, spacing 1); F trilinear,
    or the cubic B-spline whose coefficients `spline` are (grad F trilinear either way)."""
    pick = np.linspace(0, len(verts) - 1, min(samples, len(verts))).astype(int)
    x = np.clip(verts[pick].astype(np.float32), 0, np.array(volume.shape, np.float32) - 1)
    value, grad = trilinear(volume, x)
    if spline is not None:
        value = map_coordinates(spline, x.T.astype(np.float64), order=3, prefilter=False)
    return np.abs(value - np.float32(level)) / np.maximum(np.linalg.norm(grad, axis=1), 1e-12)


def vtk_smooth(verts, faces, iterations):
    """(seconds of Update(), smoothed verts) of vtkWindowedSincPolyDataFilter on the mesh."""
    from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray, vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkPoints
    from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData
    from vtkmodules.vtkFiltersCore import vtkWindowedSincPolyDataFilter
    points = vtkPoints()
    points.SetData(numpy_to_vtk(np.ascontiguousarray(verts, np.float32), deep=True))
    cells = vtkCellArray()
    offsets = np.arange(0, 3 * len(faces) + 1, 3, dtype=np.int64)
    cells.SetData(numpy_to_vtkIdTypeArray(offsets, deep=True),
                  numpy_to_vtkIdTypeArray(faces.astype(np.int64).ravel(), deep=True))
    mesh = vtkPolyData()
    mesh.SetPoints(points)
    mesh.SetPolys(cells)
    smoother = vtkWindowedSincPolyDataFilter()
    smoother.SetInputData(mesh)
    smoother.SetNumberOfIterations(iterations)
    smoother.NormalizeCoordinatesOn()
    start = time.perf_counter()
    smoother.Update()
    seconds = time.perf_counter() - start
    return seconds, vtk_to_numpy(smoother.GetOutput().GetPoints().GetData()).copy()


def quality(volume, verts, faces, level, spline, triangles=1_000_000) -> dict:
    off = off_level_voxels(volume, verts, level)
    off_spline = off_level_voxels(volume, verts, level, spline)
    angles = smallest_angles(verts, faces[np.linspace(0, len(faces) - 1, min(triangles, len(faces))).astype(int)])
    counts, _ = np.histogram(angles, bins=ANGLE_BINS)
    return {"off_median": float(np.median(off)), "off_max": float(off.max()),
            "off_spline_median": float(np.median(off_spline)),
            "slivers": float((angles < 10).mean()), "histogram": counts / len(angles)}


def bench(name: str, size: int, iterations: int, repeats: int) -> tuple[list, list]:
    make, direction = VOLUMES[name]
    log(f"{name} {size}^3: generating")
    volume = make(size)
    low, high = float(volume.min()), float(volume.max())
    levels = (0.0, LEVEL_STEP * (high - low))
    with Extractor(volume, gradient_direction=direction) as ex:
        smoother = Smoother(ex)
        turn = iter(range(10 ** 9))

        def extract():
            ex.extract(levels[next(turn) % 2])
        extract()
        mc_ms = median_ms(extract, repeats)
        smooth_times = []
        for _ in range(repeats):
            ex.extract(0.0)
            start = time.perf_counter()
            smoother.smooth(ex.mesh, iterations)
            smooth_times.append((time.perf_counter() - start) * 1000)
        smooth_ms = statistics.median(smooth_times)
        smoothed = ex.read_mesh()
        ex.extract(0.0)
        plain = ex.read_mesh()
        smoother.release()
    log(f"{name}: VTK")
    vtk_s, vtk_verts = vtk_smooth(plain[0], plain[1], iterations)
    row = [f"{name} {size}^3", f"{len(plain[1]):,}", f"{mc_ms:.0f}", f"{smooth_ms:.0f}", f"{smooth_ms / mc_ms:.2f}x",
           f"{vtk_s * 1000:.0f}"]
    quality_rows = []
    spline = spline_filter(volume.astype(np.float64), order=3)
    for label, verts in (("plain MC", plain[0]), (f"ours, {iterations} it.", smoothed[0]),
                         (f"VTK WindowedSinc, {iterations} it.", vtk_verts)):
        q = quality(volume, verts, plain[1], 0.0, spline)
        quality_rows.append([f"{name} {size}^3", label, f"{q['off_median']:.2g}", f"{q['off_max']:.2g}",
                             f"{q['off_spline_median']:.2g}",
                             f"{q['slivers']:.2%}", " ".join(f"{h:.1%}" for h in q["histogram"])])
    return row, quality_rows


def table(header, rows) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rows])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="256", help="comma-separated grid sizes (default 256)")
    parser.add_argument("--volumes", default="sphere,gyroid,noise")
    parser.add_argument("--iterations", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    times, qualities = [], []
    for size in (int(s) for s in args.sizes.split(",")):
        for name in args.volumes.split(","):
            row, quality_rows = bench(name, size, args.iterations, args.repeats)
            times.append(row)
            qualities.extend(quality_rows)
    from isoscope.gpu.context import current_or_standalone
    renderer = current_or_standalone().info["GL_RENDERER"]
    print(f"## Smoothing projected onto the level set: {renderer}, isoscope {isoscope.__version__}\n")
    print(f"### Time (median ms of {args.repeats}; smoothing = {args.iterations} iterations)\n")
    print(table(["volume", "triangles", "MC iso change", "smoothing added", "added / MC", "VTK WindowedSinc"],
                times))
    print("\n### Quality: distance off the level set (voxels; F trilinear, and F cubic spline) and smallest "
          "angles\n")
    print(table(["volume", "mesh", "off median", "off max", "off spline median", "< 10 deg",
                 "smallest angle 0-5 / 5-10 / 10-20 / 20-30 / 30-40 / 40-50 / 50-60 deg"], qualities))
    return 0


if __name__ == "__main__":
    sys.exit(main())
