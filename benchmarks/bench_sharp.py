#!/usr/bin/env python3
"""Sharp features' (Extended MC) iso change against plain marching cubes' at the same level, one run.

For each volume of benchmarks/volumes.py at each size, a resident `Extractor` alternates
between levels 0 and 0.01 (a slider drag).  Timed, as medians:

- plain: `ex.extract(level)` (the GPU mesh stays on the GPU);
- sharp: `ex.extract(level)` then `SharpenedMesh.take(ex, volume, angle)`, the viewer's iso change:
  pass 0 on the GPU (emc_flags.comp: may any cell bend past the angle?); where none may (sphere,
  gyroid at 128 and up) that is all, the extractor's mesh is drawn as it is; else the mesh read
  back, the feature step in numpy with its per-patch solve on the GPU (emc_solve.comp) and the
  crisp-normal mesh uploaded for drawing;
- numpy: extract, read back and `reference_sharp.sharpen` all in numpy (the `backend="cpu"` feature
  step on the GPU's plain mesh; what the GPU path was before emc_solve, less the drawing upload).

Prints a markdown table; ratios only mean something within one run (+-10-15% noise here).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from isoscope import Extractor  # noqa: E402
from isoscope.core.sharp.features import sharpen, signed_field  # noqa: E402
from isoscope.gpu.sharp_features import SharpenedMesh  # noqa: E402

from volumes import VOLUMES  # noqa: E402


def median_ms(run, levels, repeats):
    samples = []
    for i in range(repeats + 1):
        start = time.perf_counter()
        result = run(levels[i % 2])
        if i:  # the first run warms up (shader JIT, buffer growth)
            samples.append((time.perf_counter() - start) * 1000)
    return statistics.median(samples), result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="256", help="comma-separated samples per axis (default 256)")
    parser.add_argument("--volumes", default="sphere,gyroid,noise")
    parser.add_argument("--angle", type=float, default=30.0, help="feature angle, degrees (default 30)")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    print(f"### Sharp features (theta = {args.angle:g} deg) vs plain MC, iso change, median ms\n")
    print("| volume | n | triangles | plain | sharp | ratio | numpy | ratio | feature vertices |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for size in (int(s) for s in args.sizes.split(",")):
        for name in args.volumes.split(","):
            make, gd = VOLUMES[name]
            volume = make(size)
            with Extractor(volume, gradient_direction=gd, backend="gpu") as ex:
                levels = (0.0, 0.01)
                plain, (_, triangles) = median_ms(ex.extract, levels, args.repeats)
                field, shown = signed_field(volume, ex.descent), SharpenedMesh(ex.ctx)

                def extract_sharp(level, ex=ex, volume=volume, shown=shown):
                    ex.extract(level)
                    shown.take(ex, volume, args.angle)
                    return shown

                def extract_numpy(level, ex=ex, field=field):
                    ex.extract(level)
                    return sharpen(ex.read_mesh(), field, ex.spacing, args.angle)

                sharp, _ = median_ms(extract_sharp, levels, args.repeats)
                numpy_ms, reference = median_ms(extract_numpy, levels, args.repeats)
                assert np.array_equal(shown.read_mesh()[1], reference[1]), "the GPU path's mesh differs from numpy's"
                shown.release()
            features = len(reference[0]) - reference[4]
            print(f"| {name} | {size} | {triangles:,} | {plain:.0f} | {sharp:.0f} | {sharp / plain:.1f}x | "
                  f"{numpy_ms:.0f} | {numpy_ms / plain:.1f}x | {features:,} |", flush=True)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
