#!/usr/bin/env python3
"""The compiled CPU extractor against scikit-image and VTK Flying Edges, one-shot and iso change.

    NUMBA_NUM_THREADS=2 python benchmarks/bench_cpu.py [--volumes mni-t1,sphere,gyroid,noise] [--size 256]

- ours one-shot: `isoscope.marching_cubes(volume, level, backend="cpu")` (check, extract, arrays out);
- ours iso change: `CpuExtractor.extract(level)` on a resident volume, after an extraction at another
  level (the words' value ranges are measured then), the mesh as numpy arrays;
- scikit-image: `measure.marching_cubes` (lewiner), one-shot;
- with --gpu, `isoscope.marching_cubes(..., backend="gpu")` one-shot (its faces checked equal to ours);
- VTK vtkFlyingEdges3D (if installed) with 2 threads (`vtkSMPTools.Initialize(2)`, STDThread), normals
  on as a user gets it: one-shot builds the pipeline and updates; iso change sets a new value and updates.

Runners take turns within each round (a slow spell of the machine lands on all of them), the median
of every sample (after one warm-up round) is printed in ms.  The JIT's cold compile (an empty
NUMBA_CACHE_DIR) and cached start-up (import and first call with the cache filled) are timed in
fresh processes.  The MNI T1 (uint8,
197x233x189, levels 60/128/160/200) needs nilearn (`pip install -e .[bench]`); without it the
synthetic volumes run alone.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import isoscope  # noqa: E402
from isoscope.cpu.extractor import CpuExtractor  # noqa: E402

from volumes import REAL_VOLUMES, VOLUMES, MissingVolume, load_real  # noqa: E402

STARTUP = ("import time; t = time.perf_counter(); import numpy as np; from isoscope.cpu.compiled import "
           "marching_cubes_compiled; v = np.random.default_rng(0).normal(size=(20, 20, 20)).astype(np.float32); "
           "marching_cubes_compiled(v, 0.0); print(time.perf_counter() - t)")


def startup_seconds(cache_dir: str) -> float:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    out = subprocess.run([sys.executable, "-c", STARTUP], env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.split()[-1])


def fe_runner(threads: int):
    try:
        from vtkmodules.util import numpy_support
        from vtkmodules.vtkCommonCore import vtkSMPTools
        from vtkmodules.vtkCommonDataModel import vtkImageData
        from vtkmodules.vtkFiltersCore import vtkFlyingEdges3D
    except ImportError:
        return None
    smp = vtkSMPTools()
    smp.SetBackend("STDThread" if threads > 1 else "Sequential")
    smp.Initialize(threads)

    def build(volume):
        n0, n1, n2 = volume.shape
        scalars = numpy_support.numpy_to_vtk(volume.reshape(-1), deep=False)
        image = vtkImageData()
        image.SetDimensions(n2, n1, n0)
        image.GetPointData().SetScalars(scalars)
        fe = vtkFlyingEdges3D()
        fe.SetInputData(image)
        return fe, image, scalars

    def run(state, level):
        fe = state[0]
        fe.SetValue(0, level)
        fe.Modified()
        fe.Update()
        return fe.GetOutput().GetNumberOfPolys()
    return build, run


def timed(fn):
    start = time.perf_counter()
    result = fn()
    return (time.perf_counter() - start) * 1000.0, result


def cases(names, size):
    for name in names:
        if name in REAL_VOLUMES:
            try:
                data, spacing = load_real(name)
            except MissingVolume as exc:
                print(f"skipped {name}: {exc}")
                continue
            direction, levels = REAL_VOLUMES[name][2], REAL_VOLUMES[name][3]
            for level in levels:
                yield f"{name} @ {level:g}", data, spacing, direction, level, levels[(levels.index(level) + 1) % 4]
        else:
            generate, direction = VOLUMES[name]
            yield f"{name} {size}^3", generate(size), (1.0, 1.0, 1.0), direction, 0.0, 0.1


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--volumes", default="mni-t1,sphere,gyroid,noise")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--no-skimage", action="store_true", help="skip scikit-image (slow on big volumes)")
    parser.add_argument("--no-startup", action="store_true", help="skip the JIT compile and start-up timings")
    parser.add_argument("--gpu", action="store_true", help="also time backend='gpu' one-shot (an OpenGL 4.3 context)")
    args = parser.parse_args()

    import numba
    print(f"numba {numba.__version__}, {numba.get_num_threads()} threads (NUMBA_NUM_THREADS), "
          f"numpy {np.__version__}, OMP_WAIT_POLICY {os.environ.get('OMP_WAIT_POLICY', 'unset')} before import; "
          f"load average {os.getloadavg()[0]:.2f} (the ratios matter on a shared machine, not the ms)")
    if not args.no_startup:
        with tempfile.TemporaryDirectory() as cache:
            cold = startup_seconds(cache)
            warm = statistics.median(startup_seconds(cache) for _ in range(3))
        print(f"JIT: cold compile and first call {cold:.2f} s; cached start-up (import + first call) {warm:.2f} s")

    fe = fe_runner(2)
    skimage = None
    if not args.no_skimage:
        try:
            from skimage import measure as skimage
        except ImportError:
            pass
    columns = ["ours one-shot", "ours iso change"]
    if fe:
        columns += ["FE 2T one-shot", "FE 2T iso change"]
    if skimage:
        columns += ["scikit-image"]
    if args.gpu:
        columns += ["GPU one-shot"]
    print()
    print("| case | triangles | " + " | ".join(f"{c} ms" for c in columns) + " | FE 2T / ours, iso change "
          "| FE 2T / ours, one-shot | scikit-image / ours, one-shot |")
    print("|---|---:|" + "---:|" * (len(columns) + 3))
    for case in cases(args.volumes.split(","), args.size):
        run_case(*case, columns=columns, fe=fe, skimage=skimage, rounds=args.rounds, gpu=args.gpu)
    print(f"\nload average at the end {os.getloadavg()[0]:.2f}")


def run_case(label, volume, spacing, direction, level, other, *, columns, fe, skimage, rounds, gpu):
    """One table row: every runner `rounds` times, in turn; the medians in ms."""
    samples = {c: [] for c in columns}
    extractor = CpuExtractor(volume, spacing, direction)
    fe_state = fe[0](volume) if fe else None
    triangles = None
    for _ in range(rounds + 1):  # a first round to warm up, not counted
        ms, mesh = timed(lambda: isoscope.marching_cubes(volume, level, spacing=spacing,
                                                         gradient_direction=direction, backend="cpu"))
        samples["ours one-shot"].append(ms)
        triangles = len(mesh[1])
        extractor.extract(other)
        ms, counts = timed(lambda: extractor.extract(level))
        samples["ours iso change"].append(ms)
        assert counts[1] == triangles
        if fe:
            ms, _ = timed(lambda: fe[1](fe[0](volume), level))
            samples["FE 2T one-shot"].append(ms)
            fe[1](fe_state, other)
            ms, _ = timed(lambda: fe[1](fe_state, level))
            samples["FE 2T iso change"].append(ms)
        if skimage:
            ms, _ = timed(lambda: skimage.marching_cubes(volume, level, spacing=spacing,
                                                         gradient_direction=direction))
            samples["scikit-image"].append(ms)
        if gpu:
            ms, gpu_mesh = timed(lambda: isoscope.marching_cubes(volume, level, spacing=spacing,
                                                                 gradient_direction=direction, backend="gpu"))
            samples["GPU one-shot"].append(ms)
            assert np.array_equal(gpu_mesh[1], mesh[1])
    extractor.release()
    med = {c: statistics.median(v[1:]) for c, v in samples.items()}

    def ratio(a, b):
        return f"{med[a] / med[b]:.2f}" if a in med else "-"
    cells = [f"{med[c]:.1f}" for c in columns]
    print(f"| {label} | {triangles:,} | " + " | ".join(cells) + f" | {ratio('FE 2T iso change', 'ours iso change')}"
          f" | {ratio('FE 2T one-shot', 'ours one-shot')} | {ratio('scikit-image', 'ours one-shot')} |", flush=True)

if __name__ == "__main__":
    main()
