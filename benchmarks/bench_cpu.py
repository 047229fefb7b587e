#!/usr/bin/env python3
"""The compiled CPU extractor against scikit-image and VTK Flying Edges, one-shot and iso change.

    NUMBA_NUM_THREADS=2 python benchmarks/bench_cpu.py [--volumes mni-t1,sphere,gyroid,noise] [--size 256]
    python benchmarks/bench_cpu.py --arrays          # the arrays as users have them, with GL and without

--arrays: `isoscope.marching_cubes(array, level, spacing=...)` with the default backend, one-shot, on the
arrays exactly as nibabel returns them (`np.asarray(nibabel.load(path).dataobj)`: Fortran order, the file's
dtype): the MNI T1 (uint8) and a CT-like 512x512x400 int16 torso written once as NIfTI (a memory map, as
nibabel gives an uncompressed file), and the MNI T1 as C-ordered float32; beside VTK Flying Edges with 2
threads given the same array without a copy (a Fortran array is VTK's native x-fastest layout:
SetDimensions(n0, n1, n2)), in the same process, in turns; then the resident iso change on the MNI T1.  The
whole table again in a child process without GL (its EGL vendor path pointing at nothing, no DISPLAY), where
backend="auto" has no context to find.

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
        """The pipeline on `volume`'s own memory: a C array as an n2 x n1 x n0 image (x = axis 2), a Fortran
        one (nibabel's) as n0 x n1 x n2 (x = axis 0, VTK's native layout), neither copied."""
        n0, n1, n2 = volume.shape
        fortran = volume.flags.f_contiguous and not volume.flags.c_contiguous
        scalars = numpy_support.numpy_to_vtk(volume.ravel(order="F" if fortran else "C"), deep=False)
        image = vtkImageData()
        image.SetDimensions(*((n0, n1, n2) if fortran else (n2, n1, n0)))
        image.GetPointData().SetScalars(scalars)
        fe = vtkFlyingEdges3D()
        fe.SetInputData(image)
        return fe, image, scalars, volume

    def run(state, level):
        fe = state[0]
        fe.SetValue(0, level)
        fe.Modified()
        fe.Update()
        return fe.GetOutput().GetNumberOfPolys()
    return build, run


def timed(fn, *args, **kwargs):
    start = time.perf_counter()
    result = fn(*args, **kwargs)
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


def as_given_cases(cache: Path):
    """(label, array as the user has it, spacing, levels, resident iso change too) for --arrays."""
    from volumes import as_nibabel_gives, ct_torso_nifti, real_volume_path
    try:
        mri, mri_spacing = as_nibabel_gives(real_volume_path("mni-t1"))
    except MissingVolume as exc:
        print(f"skipped the MNI T1: {exc}")
        mri = None
    if mri is not None:
        yield "MNI T1 197x233x189 uint8, as nibabel gives it (Fortran)", mri, mri_spacing, (128.0,), True
    ct, ct_spacing = as_nibabel_gives(ct_torso_nifti(cache))
    yield "CT-like 512x512x400 int16, as nibabel gives it (Fortran, memory map)", ct, ct_spacing, (300.0, -300.0), False
    if mri is not None:
        yield "MNI T1 as C-ordered float32", np.ascontiguousarray(mri, np.float32), mri_spacing, (128.0,), False


def run_arrays(rounds: int, cache: Path) -> None:
    """The --arrays table in this process's GL situation."""
    from isoscope.gpu.context import describe
    fe = fe_runner(2)
    if fe is None:
        print("VTK is not installed (pip install -e .[bench]): no Flying Edges to compare with")
        return
    print(describe().replace("\n", "; "))

    def fe_once(volume, level):  # a pipeline built and run, as a one-shot call does
        return fe[1](fe[0](volume), level)
    print()
    print("| array, as the user has it | level | triangles | ours ms (default backend) | FE 2T ms | FE 2T / ours |")
    print("|---|---:|---:|---:|---:|---:|")
    resident = []
    for label, volume, spacing, levels, iso_change in as_given_cases(cache):
        for level in levels:
            samples = {"ours": [], "fe": []}
            triangles = None
            for _ in range(rounds + 1):  # a first round to warm up, not counted
                ms, mesh = timed(isoscope.marching_cubes, volume, level, spacing=spacing)
                samples["ours"].append(ms)
                triangles = len(mesh[1])
                ms, theirs = timed(fe_once, volume, level)
                samples["fe"].append(ms)
                assert theirs == triangles, (theirs, triangles)
            ours, theirs = (statistics.median(samples[k][1:]) for k in ("ours", "fe"))
            print(f"| {label} | {level:g} | {triangles:,} | {ours:.1f} | {theirs:.1f} | x{theirs / ours:.2f} |",
                  flush=True)
        if iso_change:
            resident.append((label, volume, spacing))
    for label, volume, spacing in resident:
        print()
        print("| resident iso change, 128 <-> 129 | ours ms | FE 2T ms | FE 2T / ours |")
        print("|---|---:|---:|---:|")
        fe_state = fe[0](volume)
        from isoscope.gpu.context import gl_available
        for backend in ("auto", "cpu") + (("gpu",) if gl_available() else ()):
            extractor = isoscope.Extractor(volume, spacing, backend=backend)
            samples = {"ours": [], "fe": []}
            for n in range(2 * rounds + 2):
                level = (128.0, 129.0)[n % 2]
                samples["ours"].append(timed(extractor.extract, level)[0])
                samples["fe"].append(timed(fe[1], fe_state, level)[0])
            extractor.release()
            ours, theirs = (statistics.median(samples[k][2:]) for k in ("ours", "fe"))
            kind = type(extractor).__name__
            print(f"| {label}, Extractor(backend={backend!r}): {kind} | {ours:.1f} | {theirs:.1f} | "
                  f"x{theirs / ours:.2f} |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--arrays", action="store_true",
                        help="the arrays as users have them (see above), with GL and then without")
    parser.add_argument("--without-gl", action="store_true", help=argparse.SUPPRESS)  # the child's half
    parser.add_argument("--cache", default=str(Path(tempfile.gettempdir()) / "isoscope-bench"),
                        help="where --arrays writes its CT-like NIfTI once (about 200 MB)")
    parser.add_argument("--volumes", default="mni-t1,sphere,gyroid,noise")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--no-skimage", action="store_true", help="skip scikit-image (slow on big volumes)")
    parser.add_argument("--no-startup", action="store_true", help="skip the JIT compile and start-up timings")
    parser.add_argument("--gpu", action="store_true", help="also time backend='gpu' one-shot (an OpenGL 4.3 context)")
    args = parser.parse_args()
    if args.arrays:
        Path(args.cache).mkdir(parents=True, exist_ok=True)
        if args.without_gl:
            print("\n### Without GL\n")
            run_arrays(args.rounds, Path(args.cache))
            return
        print("### With GL as this machine has it\n")
        run_arrays(args.rounds, Path(args.cache))
        env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
        env.update({"__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent.json", "GLCONTEXT_LINUX_LIBGL": "/nonexistent"})
        subprocess.run([sys.executable, __file__, "--arrays", "--without-gl", "--rounds", str(args.rounds),
                        "--cache", args.cache], env=env, check=True)
        return

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
