#!/usr/bin/env python3
"""topology="trilinear" (issue 38): how often each mesh has the trilinear interpolant's pieces and Euler
characteristic, and what the mode costs.

    NUMBA_NUM_THREADS=2 python benchmarks/bench_topology.py [--grids 1000] [--size 128] [--rounds 7]

Agreement: random 3x3x3 grids of normal samples at level 0 (ambiguous faces and cells everywhere); the
oracle samples the trilinear interpolant 16 and 32 times per cell edge (scipy's order-1 map_coordinates),
meshes it with scikit-image and counts pieces and V - E + F, vertices merged by position
(tests/support/topology.py, the suite's oracle); grids where the two refinements disagree are left out.
Then isoscope's montani (default) and trilinear meshes and scikit-image's Lewiner (MC33) mesh are counted
the same way.  First, the same three meshes on MC33's 33 configurations built by hand (tests/support/mc33.py) in
all 96 turns of the cell, against each configuration's own pieces and Euler characteristic.

Cost: one-shot `isoscope.marching_cubes(volume, level, topology=...)` with the default backend and scikit-image's
`measure.marching_cubes` (lewiner) on the MNI T1 (as nibabel gives it: Fortran uint8; needs nilearn), the
smoothed noise and the gyroid of benchmarks/volumes.py at --size, runners in turns, medians in ms.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))   # the suite's oracle, not a second copy of it
from support.mc33 import MC33, grid, symmetries  # noqa: E402
from support.topology import configuration, counts, oracle, single_cells  # noqa: E402

import isoscope  # noqa: E402

from volumes import MissingVolume, as_nibabel_gives, gyroid, noise, real_volume_path  # noqa: E402


def agreement(grids: int, seed: int) -> None:
    from skimage import measure
    rng = np.random.default_rng(seed)
    sure, hits, misses = 0, {"montani": 0, "trilinear": 0, "scikit-image lewiner": 0}, []
    started = time.perf_counter()
    for _ in range(grids):
        field = rng.standard_normal((3, 3, 3)).astype(np.float32)
        truth = oracle(field, refinements=(16, 32))
        if truth is None:
            continue
        sure += 1
        for topology in ("montani", "trilinear"):
            mesh = isoscope.marching_cubes(field, 0.0, backend="cpu", topology=topology)
            hits[topology] += counts(mesh[0], mesh[1]) == truth
            if topology == "trilinear" and counts(mesh[0], mesh[1]) != truth:
                misses.append((counts(mesh[0], mesh[1]), truth, oracle(field, refinements=(48, 96))))
        verts, faces, _, _ = measure.marching_cubes(field, 0.0, method="lewiner")
        hits["scikit-image lewiner"] += counts(verts, faces) == truth
    print(f"\n{grids} random 3x3x3 grids, seed {seed}: the oracle sure of {sure} "
          f"({time.perf_counter() - started:.0f} s)\n")
    print("| mesh | pieces and Euler characteristic as the interpolant's |\n|---|---:|")
    for name, hit in hits.items():
        print(f"| {name} | {hit} / {sure} ({100 * hit / max(sure, 1):.1f}%) |")
    for ours, coarse, fine in misses:   # a feature thinner than a 32nd of a cell: looked at closer
        print(f"trilinear {ours} where the oracle said {coarse}; refined 48 and 96 times it says {fine}")


def every_key(seed: int) -> None:
    """Each table key that random single cells reach, once, against the oracle (16 and 32; closer where they
    differ from trilinear's mesh)."""
    from isoscope.cpu.trilinear import marching_cubes_trilinear
    started = time.perf_counter()
    cells = single_cells(seed=seed)
    sure = agree = 0
    families = set()
    for key, field in cells.items():
        truth = oracle(field, refinements=(16, 32))
        got = counts(*marching_cubes_trilinear(field, 0.0)[:2])
        if truth is not None and got != truth:
            truth = oracle(field, refinements=(48, 96))
        if truth is None:
            continue
        sure += 1
        agree += got == truth
        families.add(configuration(key))
        if got != truth:
            print(f"key {key} ({configuration(key)}): trilinear {got}, the interpolant {truth}")
    print(f"\nevery key single cells reach: {len(cells)} keys in {len(families)} configurations, the oracle sure "
          f"of {sure}, trilinear agrees on {agree} ({time.perf_counter() - started:.0f} s)")


def configurations() -> None:
    """MC33's 33 configurations built by hand (tests/support/mc33.py), each in its 96 rotations, mirror images and
    inside/outside swaps: how many turns each mesh gives the configuration's pieces and Euler characteristic."""
    from skimage import measure

    from isoscope.cpu.trilinear import marching_cubes_trilinear
    meshes = {"montani": lambda f: isoscope.api.outward_marching_cubes(f, 0.0, backend="cpu"),
              "trilinear": lambda f: marching_cubes_trilinear(f, 0.0),
              "scikit-image lewiner": lambda f: measure.marching_cubes(f, 0.0, method="lewiner")}
    hits = {name: 0 for name in meshes}
    wrong = {name: [] for name in meshes}
    turns = 0
    for configuration_name, (values, expected) in MC33.items():
        if expected == (0, 0):
            continue   # no surface: nothing to mesh (scikit-image refuses the level)
        misses = dict.fromkeys(meshes, 0)
        for field in symmetries(grid(values)):
            turns += 1
            for name, mesh in meshes.items():
                verts, faces = mesh(field)[:2]
                misses[name] += counts(verts, faces) != expected
        for name, missed in misses.items():
            hits[name] += 96 - missed
            if missed:
                wrong[name].append(f"{configuration_name} ({missed})")
    print(f"\nMC33's configurations built by hand, 32 with a surface x 96 turns = {turns} cells\n")
    print("| mesh | turns with the configuration's pieces and Euler characteristic | configurations missed (turns) |"
          "\n|---|---:|---|")
    for name, hit in hits.items():
        print(f"| {name} | {hit} / {turns} ({100 * hit / turns:.1f}%) | {', '.join(wrong[name]) or 'none'} |")


def cost(size: int, rounds: int) -> None:
    from skimage import measure
    volumes = []
    try:
        data, spacing = as_nibabel_gives(real_volume_path("mni-t1"))
        volumes.append(("MNI T1 197x233x189 uint8 (Fortran)", data, 128.0))
    except MissingVolume as exc:
        print(f"(no MRI: {exc})")
    volumes += [(f"noise {size}^3", noise(size), 0.0), (f"gyroid {size}^3", gyroid(size), 0.0)]
    runners = {
        "montani": lambda v, lvl: isoscope.marching_cubes(v, lvl),   # the default backend, as a user calls it
        "trilinear": lambda v, lvl: isoscope.marching_cubes(v, lvl, topology="trilinear"),
        "scikit-image lewiner": lambda v, lvl: measure.marching_cubes(np.asarray(v, np.float32), lvl),
    }
    print("\n| volume | montani ms (triangles) | trilinear ms (triangles) | trilinear / montani | "
          "scikit-image ms | scikit-image / trilinear |\n|---|---|---|---:|---:|---:|")
    for name, volume, level in volumes:
        times = {runner: [] for runner in runners}
        sizes = {}
        for round_ in range(rounds + 1):
            for runner, call in runners.items():
                started = time.perf_counter()
                mesh = call(volume, level)
                if round_:   # the first round warms up (numba's cache, the table)
                    times[runner].append((time.perf_counter() - started) * 1000)
                sizes[runner] = len(mesh[1])
        ms = {runner: statistics.median(t) for runner, t in times.items()}
        print(f"| {name} | {ms['montani']:.1f} ({sizes['montani']:,}) | {ms['trilinear']:.1f} "
              f"({sizes['trilinear']:,}) | x{ms['trilinear'] / ms['montani']:.2f} | "
              f"{ms['scikit-image lewiner']:.1f} | x{ms['scikit-image lewiner'] / ms['trilinear']:.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grids", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    if args.grids:
        configurations()
        agreement(args.grids, args.seed)
        every_key(args.seed)
    if args.rounds:
        cost(args.size, args.rounds)


if __name__ == "__main__":
    main()
