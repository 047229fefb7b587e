#!/usr/bin/env python3
"""Each extraction mode's iso change against plain marching cubes', in one process (issue 9).

For each volume of benchmarks/volumes.py at each size, one resident `Extractor` holds
the volume; every mode extracts from it, alternating between level 0 and 0 + 0.5% of
the data range (a slider drag, as bench_extract.py's "iso change"), the modes' runs
interleaved so that the machine's load hits them alike, and only the `extract(level)`
call is timed (it returns when the GPU is done).  Modes:

- cubes: `Extractor.extract`, plain marching cubes;
- tetrahedra: `TetraExtractor(extractor).extract`, marching tetrahedra on the same
  resident volume (no upload of its own);
- trilinear: `trilinear_on(extractor).extract`, cubes with the trilinear interpolant's
  topology (issue 38) on the same resident volume.

It prints a markdown table: per volume, each mode's median ms, its triangles and its
time as a multiple of cubes' (the target for tetrahedra: <= 2.5x).  Ratios, not absolute
times, are what one run on a shared machine can compare.

    python benchmarks/bench_modes.py                    # 256^3 sphere, gyroid, noise
    python benchmarks/bench_modes.py --sizes 64 --repeats 2
"""
from __future__ import annotations

import argparse
import gc
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_extract import LEVEL_STEP, fmt_ms, log, summary, timed  # noqa: E402

from isoscope.gpu.cubes import Extractor  # noqa: E402
from isoscope.gpu.tetra import TetraExtractor  # noqa: E402
from isoscope.gpu.trilinear import trilinear_on  # noqa: E402

from volumes import VOLUMES  # noqa: E402

MODES = {  # name: make(extractor) -> an object with extract(level) and release(), sharing its volume
    "cubes": lambda cubes: cubes,
    "tetrahedra": TetraExtractor,
    "trilinear": trilinear_on,
}
TARGETS = {"tetrahedra": 2.5}  # at most this many times cubes' iso change


def bench_volume(volume, gd, repeats, warmup) -> dict:
    """Runs interleaved (cubes, tetrahedra, cubes, ...), so a change in the machine's load hits
    every mode alike; each mode's own runs alternate between the two levels."""
    lo, hi = float(volume.min()), float(volume.max())
    levels = (0.0, float(np.float32(LEVEL_STEP * (hi - lo))))
    with Extractor(volume, gradient_direction=gd) as cubes:
        modes = {name: make(cubes) for name, make in MODES.items()}
        try:
            samples = {name: [] for name in modes}
            triangles = {}
            for i in range(max(warmup, 1) + repeats):  # at least one untimed run: it allocates the mesh buffers
                for name, mode in modes.items():
                    ms, (_, n) = timed(mode.extract, levels[i % 2])
                    if i % 2 == 0:
                        triangles[name] = n
                    if i >= max(warmup, 1):
                        samples[name].append(ms)
            return {name: {**summary(samples[name]), "triangles": triangles[name],
                           "scratch_bytes": mode.scratch_bytes()} for name, mode in modes.items()}
        finally:
            for mode in modes.values():
                if mode is not cubes:
                    mode.release()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", default="256", help="comma-separated edge lengths (default 256)")
    parser.add_argument("--volumes", default=",".join(VOLUMES), help=f"comma-separated: {','.join(VOLUMES)}")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per mode (default 5)")
    parser.add_argument("--warmup", type=int, default=2, help="untimed runs first (default 2)")
    args = parser.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")]
    names = [v.strip() for v in args.volumes.split(",") if v.strip()]
    rows = ["| size | volume | mode | median ms | min ms | triangles | x cubes' time | scratch B/voxel |",
            "|---|---|---|---:|---:|---:|---:|---:|"]
    for n in sizes:
        for name in names:
            make, gd = VOLUMES[name]
            log(f"[{n}^3 {name}]")
            volume = make(n)
            results = bench_volume(volume, gd, args.repeats, args.warmup)
            base = results["cubes"]["median_ms"]
            for mode, r in results.items():
                ratio = r["median_ms"] / base
                target = f" (target <= {TARGETS[mode]})" if mode in TARGETS else ""
                rows.append(f"| {n}^3 | {name} | {mode} | {fmt_ms(r['median_ms'])} | {fmt_ms(r['min_ms'])} | "
                            f"{r['triangles']:,} | {ratio:.2f}{target} | {r['scratch_bytes'] / volume.size:.3f} |")
            del volume
            gc.collect()
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
