#!/usr/bin/env python3
"""Benchmark isoscope's extraction against scikit-image, PyMCubes and VTK Flying Edges.

One process, one run, so the ratios are measured under the same machine load
(on a shared box run-to-run noise is +-10-15%: compare ratios, not absolute ms).
For each volume of benchmarks/volumes.py and each size (or each real scan of
volumes.REAL_VOLUMES, or a volume file, at each of its levels) it times, as medians:

- ours, iso change: a resident `Extractor`, alternating between two nearby levels
  (a slider drag); only `ex.extract(level)` is timed (it returns when the GPU is done);
- ours, first: `isoscope.marching_cubes(vol, 0, backend="gpu")`, upload and read-back
  included, context creation and shader compilation not (a warm-up call does them); the
  GPU memory the last call kept (app/extractor_pool.py) is reused, as in a loop of calls;
  "fresh memory" is the same call after `isoscope.release_gpu_memory()` each time (a
  process's first call on a volume of a new shape or sample type);
- ours, numpy: `isoscope.marching_cubes(vol, 0, backend="cpu")` (not above 256^3);
- ours, default backend: `isoscope.marching_cubes(vol, level)` as a script calls it (backend="auto": the
  compiled CPU extractor on a software renderer or without GL, the GPU on graphics hardware);
- each peer re-run at the new level the way its users would: scikit-image
  (lewiner), PyMCubes, and VTK vtkFlyingEdges3D on an already-built pipeline
  (`SetValue(0, level)`, `Modified()`, `Update()`) with 2 threads (STDThread) and 1
  (Sequential). A peer keeps nothing between levels, so its time serves both as
  its "iso change" and as its "first".

Real scans (and the CT-like torso, `ct-torso`) are given to every runner C-ordered, unless --as-given:
then exactly as nibabel returns them (`np.asarray(image.dataobj)`: Fortran order, the file's dtype), and VTK
wraps a Fortran array as its native x-fastest image without a copy (SetDimensions(n0, n1, n2)), as PyVista
does.

It prints a markdown table (stdout; progress goes to stderr) and can write JSON.
Run `python benchmarks/bench_extract.py --help`; see benchmarks/README.md.
"""
from __future__ import annotations

import argparse
import datetime
import functools
import gc
import importlib
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

sys.path.insert(0, str(HERE))
try:  # an installed isoscope (editable or not)
    import isoscope
except ImportError:  # the source folder is app/, so the checkout alone cannot be imported as isoscope
    sys.exit("bench_extract.py: isoscope is not installed; run `python3 -m pip install -e .` first")

from volumes import (  # noqa: E402
    CT_LEVELS,
    REAL_VOLUMES,
    VOLUMES,
    MissingVolume,
    as_nibabel_gives,
    ct_torso_nifti,
    load_real,
    real_volume_path,
)

LEVEL_STEP = 0.005  # the second level: 0 + 0.5% of the data range, one notch of a 200-step slider
TRIANGLE_TOLERANCE = 0.03  # peers must agree with our triangle count within 3%
LEVEL_TOLERANCE = 1e-4  # the median vertex may be off the level by this x the data range
CPU_MAX_SIZE = 256  # the numpy reference is skipped above this


def log(*parts) -> None:
    print(*parts, file=sys.stderr, flush=True)


def off_level(volume: np.ndarray, points: np.ndarray, level: float, samples: int = 2000) -> float:
    """Median |field - level| over up to `samples` mesh vertices read in array-index order.

    The field is interpolated trilinearly, which on the grid edge a marching-cubes
    vertex lies on is the linear interpolation that placed it: a right mesh gives
    ~0, a mesh whose axes are swapped (VTK's x is numpy's last axis) does not.
    The median, not the maximum: isoscope keeps vertices a margin away from the
    grid points (so a tie never puts two vertices at one place), which moves a
    few vertices slightly off the level by design.
    """
    if len(points) == 0:
        return 0.0
    p = np.asarray(points, np.float64)[np.linspace(0, len(points) - 1, min(samples, len(points))).astype(int)]
    lo = np.clip(np.floor(p).astype(np.int64), 0, np.array(volume.shape) - 2)
    t = np.clip(p - lo, 0.0, 1.0)
    value = np.zeros(len(p))
    for corner in np.ndindex(2, 2, 2):
        weight = np.prod(np.where(corner, t, 1.0 - t), axis=1)
        i, j, k = (lo + corner).T
        value += weight * volume[i, j, k]
    return float(np.median(np.abs(value - level)))


# -- peers ------------------------------------------------------------------------------------

class Peer:
    """A peer library: `prepare` (untimed) builds what a user keeps; `run` is what is timed."""

    key = ""
    label = ""
    module = ""

    def __init__(self):
        self.missing = None
        try:
            self.lib = importlib.import_module(self.module)
        except Exception as exc:  # ImportError, or a broken install
            self.missing = f"{type(exc).__name__}: {exc}"

    @property
    def version(self) -> str:
        return getattr(self.lib, "__version__", "?")

    def activate(self) -> None:
        """Called before a series of runs (VTK: pick the threading backend)."""

    def prepare(self, volume, gradient_direction):
        return volume, gradient_direction

    def run(self, state, level: float, want_points: bool = False):
        """-> (triangle count, the vertices in array-index order if asked, else None)."""
        raise NotImplementedError


class SkimagePeer(Peer):
    key, label, module = "skimage", "scikit-image (lewiner)", "skimage.measure"

    @property
    def version(self):
        return importlib.import_module("skimage").__version__

    def run(self, state, level, want_points=False):
        volume, gradient_direction = state
        verts, faces, _, _ = self.lib.marching_cubes(volume, level, gradient_direction=gradient_direction)
        return len(faces), verts if want_points else None


class MCubesPeer(Peer):
    key, label, module = "mcubes", "PyMCubes", "mcubes"

    @property
    def version(self):
        from importlib.metadata import version
        return version("PyMCubes")

    def run(self, state, level, want_points=False):
        vertices, triangles = self.lib.marching_cubes(state[0], level)
        return len(triangles), vertices if want_points else None


class FlyingEdgesPeer(Peer):
    module = "vtkmodules.vtkFiltersCore"

    def __init__(self, threads: int):
        self.threads = threads
        self.backend = "STDThread" if threads > 1 else "Sequential"
        self.key = f"fe{threads}"
        self.label = f"VTK FlyingEdges3D {threads}T"
        super().__init__()
        if self.missing is None:
            try:
                from vtkmodules.util import numpy_support
                from vtkmodules.vtkCommonCore import vtkSMPTools
                from vtkmodules.vtkCommonDataModel import vtkImageData
            except Exception as exc:
                self.missing = f"{type(exc).__name__}: {exc}"
            else:
                self.numpy_support, self.smp, self.image_data = numpy_support, vtkSMPTools, vtkImageData

    @property
    def version(self):
        from vtkmodules.vtkCommonCore import vtkVersion
        return vtkVersion.GetVTKVersion()

    def activate(self):
        if not self.smp.SetBackend(self.backend):
            raise RuntimeError(f"VTK has no SMP backend {self.backend}")
        self.smp.Initialize(self.threads)  # after SetBackend: each backend keeps its own count
        self.active_threads = self.smp.GetEstimatedNumberOfThreads()

    def prepare(self, volume, gradient_direction):
        # A C-order (n0, n1, n2) array has axis 2 varying fastest, which is VTK's x: the image is
        # n2 x n1 x n0 and shares numpy's memory (no copy, no transpose); its points come out as
        # (x, y, z) = (axis 2, axis 1, axis 0).  A Fortran-order array (nibabel's) has axis 0 fastest:
        # VTK's native layout, an n0 x n1 x n2 image on the same memory, points in axis order.
        fortran = volume.flags.f_contiguous and not volume.flags.c_contiguous
        if not fortran:
            volume = np.ascontiguousarray(volume)
        n0, n1, n2 = volume.shape
        scalars = self.numpy_support.numpy_to_vtk(volume.ravel(order="F" if fortran else "C"), deep=False)
        image = self.image_data()
        image.SetDimensions(*((n0, n1, n2) if fortran else (n2, n1, n0)))
        image.GetPointData().SetScalars(scalars)
        fe = self.lib.vtkFlyingEdges3D()  # defaults, as a user gets them: normals on
        fe.SetInputData(image)
        return fe, image, scalars, volume, fortran  # keep the numpy memory alive as long as VTK uses it

    def run(self, state, level, want_points=False):
        fe, fortran = state[0], state[4]
        fe.SetValue(0, level)
        fe.Modified()
        fe.Update()
        output = fe.GetOutput()
        points = None
        if want_points:
            points = np.zeros((0, 3))
            if output.GetNumberOfPoints():  # (x, y, z) -> array-index order (axis 0, 1, 2)
                points = self.numpy_support.vtk_to_numpy(output.GetPoints().GetData())
                points = points if fortran else points[:, ::-1]
        return output.GetNumberOfPolys(), points


def make_peers() -> list[Peer]:
    return [SkimagePeer(), MCubesPeer(), FlyingEdgesPeer(2), FlyingEdgesPeer(1)]


# -- timing -----------------------------------------------------------------------------------

def timed(fn, *args):
    start = time.perf_counter()
    result = fn(*args)
    return (time.perf_counter() - start) * 1000.0, result


SETTLE_SECONDS = 0.5
"""Untimed runs go on for at least this long (when there are any), for every runner alike: on this
2-vCPU VM our resident extractor's first ~8-10 extractions ran up to 1.8x slower than later ones
(~0.1-0.4 s; the MNI T1 @ 60, the first case of a run, read 10.2 ms against a steady 6.9)."""


def alternate(run, levels, start, untimed, repeats, after_timed=None, settle=True):
    """Runs run(level) -> triangles at a, b, a, ... (from levels["ab"[start]]): `untimed` runs (and,
    with `settle`, more until SETTLE_SECONDS have passed), then `repeats` timed ones, so every run
    follows one at the other level, like a slider drag.

    The untimed runs let the allocator settle: here the first two or three runs at a new size
    in a process are up to 1.5x slower for every library alike (fresh pages for fresh outputs).
    """
    triangles, samples = {}, []
    settled_at = time.perf_counter() + SETTLE_SECONDS
    done = 0
    while done < untimed or (untimed and settle and time.perf_counter() < settled_at):
        which = "ab"[(start + done) % 2]
        _, triangles[which] = timed(run, levels[which])
        done += 1
    for i in range(done, done + repeats):
        which = "ab"[(start + i) % 2]
        ms, triangles[which] = timed(run, levels[which])
        samples.append(ms)
        if after_timed:
            after_timed()
    return summary(samples), triangles


def summary(samples: list[float]) -> dict:
    return {"median_ms": statistics.median(samples), "min_ms": min(samples),
            "samples_ms": [round(s, 3) for s in samples]}


def bench_ours_first(volume, gd, level, repeats, backend, untimed, fresh=False):
    """One-shot calls.  The GPU keeps the last call's extractor for the next (app/extractor_pool.py);
    `fresh`: each call starts without it (isoscope.release_gpu_memory() before it, untimed), as a
    process's first call on a volume of a new shape does."""
    last = {}

    def run(level):
        last["verts"], faces, _, _ = isoscope.marching_cubes(volume, level, gradient_direction=gd, backend=backend)
        return len(faces)

    release = getattr(isoscope, "release_gpu_memory", None) if fresh else None
    if release is not None:
        release()
    result, triangles = alternate(run, {"a": level, "b": level}, 0, untimed, repeats, after_timed=release)
    return {**result, "triangles": {"a": triangles["a"]}, "off_level": off_level(volume, last.pop("verts"), level)}


def bench_ours_iso_change(volume, gd, levels, repeats, untimed):
    from isoscope.gpu.cubes import Extractor
    ex = Extractor(volume, gradient_direction=gd)
    try:
        scratch, gpu_ms, active = [ex.scratch_bytes()], [], []

        def after_timed():
            scratch.append(ex.scratch_bytes())
            if getattr(ex, "brick_count", 0):  # empty-space skipping: the share of bricks the level cut
                active.append(getattr(ex, "active_bricks", 0) / ex.brick_count)
            if getattr(ex, "last_gpu_ms", None) is not None:
                gpu_ms.append(float(ex.last_gpu_ms))

        # At least one untimed run: the first extraction allocates the mesh buffers (with --warmup 0 only that
        # one, without the settling time).
        result, triangles = alternate(lambda level: ex.extract(level)[1], levels, 0, max(untimed, 1),
                                      repeats, after_timed, settle=untimed > 0)
        result.update(triangles=triangles, scratch_bytes=max(scratch), renderer=ex.ctx.info["GL_RENDERER"])
        if gpu_ms:
            result["gpu_median_ms"] = statistics.median(gpu_ms)
        if active:
            result["active_brick_share"] = max(active)
        return result
    finally:
        ex.release()


def run_peer_once(peer, state, level):
    """The peer's triangle count at `level` (its points are not wanted)."""
    return peer.run(state, level)[0]


def bench_peer(peer, volume, gd, levels, repeats, untimed):
    peer.activate()
    state = peer.prepare(volume, gd)
    try:
        # The first run (untimed) sets the peer up and gives the axis-order check.
        n_a, points = peer.run(state, levels["a"], want_points=True)
        check = off_level(volume, points, levels["a"])
        del points
        result, triangles = alternate(functools.partial(run_peer_once, peer, state), levels, 1,
                                      max(untimed - 1, 0), repeats)
        result.update(triangles={"a": n_a, **triangles}, off_level=check)
        if hasattr(peer, "active_threads"):
            result["threads"] = peer.active_threads
        return result
    finally:
        del state
        gc.collect()


def warm_up(peers, busy_seconds: float = 1.0) -> str:
    """Create the GL context, compile the shaders and load every peer's code, on a tiny volume."""
    busy = np.random.default_rng(0).random((600, 600))
    until = time.perf_counter() + busy_seconds
    while time.perf_counter() < until:  # both cores busy for a second: this VM ramps idle vCPUs up slowly
        busy @ busy
    tiny = VOLUMES["sphere"][0](12)
    levels = {"a": 0.0, "b": 0.05}
    bench_ours_first(tiny, "ascent", 0.0, 1, "gpu", 1)
    ours = bench_ours_iso_change(tiny, "ascent", levels, 2, 1)
    for peer in peers:
        if peer.missing is None:
            bench_peer(peer, tiny, "ascent", levels, 1, 1)
    return ours["renderer"]


# -- checks -----------------------------------------------------------------------------------

def check_case(case) -> list[str]:
    """Triangle counts against ours at each level measured; every mesh's vertices on the level set."""
    warnings = []
    name = f"{case_name(case)} {case['grid']}"
    ours = case["ours"]["iso_change"]["triangles"]
    first = case["ours"]["first"]
    if first["triangles"]["a"] != ours["a"]:
        warnings.append(f"{name}: isoscope.marching_cubes gave {first['triangles']['a']} triangles, "
                        f"the resident Extractor {ours['a']}, at the same level")
    cpu = case["ours"].get("numpy")
    if cpu and cpu["triangles"]["a"] != ours["a"]:
        warnings.append(f"{name}: numpy reference {cpu['triangles']['a']} triangles, GPU {ours['a']}")
    for result in case["peers"].values():
        if "median_ms" not in result:
            continue
        for which, count in result["triangles"].items():
            expected = ours.get(which)
            if expected and abs(count - expected) > TRIANGLE_TOLERANCE * expected:
                warnings.append(f"{name}: {result['label']} has {count} triangles at level "
                                f"{case['levels'][which]:g}, ours {expected} "
                                f"({100.0 * (count - expected) / expected:+.1f}%)")
    tolerance = LEVEL_TOLERANCE * (case["value_range"][1] - case["value_range"][0])
    runners = [("isoscope.marching_cubes (GPU)", first), ("numpy reference", cpu)]
    runners += [(r["label"], r) for r in case["peers"].values() if "median_ms" in r]
    for label, result in runners:
        if result and result["off_level"] > tolerance:
            warnings.append(f"{name}: {label}'s vertices, read in array-index order, are off the level "
                            f"by {result['off_level']:.3g} (median; axes swapped?)")
    return warnings


# -- the run ----------------------------------------------------------------------------------

def plan(args) -> list[dict]:
    """What to run: a synthetic volume per size at level 0; a real scan or a file at each of its levels."""
    cases = [synthetic(size, name) for size in args.sizes for name in args.volumes if name in VOLUMES]
    if args.big and not any(c["grid"] == "512^3" and c["volume"] == "sphere" for c in cases):
        cases.append(synthetic(512, "sphere"))
    for name in args.volumes:
        if name in REAL_VOLUMES:
            gd, levels = REAL_VOLUMES[name][2], REAL_VOLUMES[name][3]
            load = (lambda name=name: as_nibabel_gives(real_volume_path(name))[0]) if args.as_given else \
                (lambda name=name: load_real(name)[0])
            cases.append({"volume": name, "load": load, "gd": gd, "levels": args.levels or levels})
        elif name == "ct-torso":
            def load_ct():
                data = as_nibabel_gives(ct_torso_nifti(args.cache))[0]
                return data if args.as_given else np.ascontiguousarray(data)
            cases.append({"volume": name, "load": load_ct, "gd": "descent", "levels": args.levels or CT_LEVELS})
        elif name not in VOLUMES:  # a file, checked by parse_args
            cases.append({"volume": Path(name).name, "load": lambda name=name: load_file(name, args.as_given),
                          "gd": "descent",
                          "levels": args.levels, "fractions": (0.25, 0.5, 0.75)})
    return cases


def synthetic(size: int, name: str) -> dict:
    generate, gd = VOLUMES[name]
    return {"volume": name, "load": lambda: generate(size), "gd": gd, "levels": (0.0,), "synthetic": True}


def load_file(path: str, as_given: bool = False) -> np.ndarray:
    from isoscope.volumes import open_volume
    data = open_volume(path).data  # in the file's own memory order (a NIfTI's is Fortran)
    return np.asarray(data) if as_given else np.ascontiguousarray(data)


def repeats_for(voxels: int, args) -> int:
    if args.repeats:
        return args.repeats
    return 5 if voxels <= 128 ** 3 else 3


def run_cases(spec, peers, args) -> list[dict]:
    """One case per level of the spec, all on one loaded volume."""
    log(f"[{spec['volume']}] loading")
    volume = spec["load"]()
    if args.float32:
        volume = volume.astype(np.float32)
    lo, hi = float(volume.min()), float(volume.max())
    levels = spec["levels"] or [lo + f * (hi - lo) for f in spec["fractions"]]
    cases = [merge_rounds([run_case(volume, spec, level, peers, args) for _ in range(args.rounds)])
             for level in levels]
    del volume
    gc.collect()
    return cases


def merge_rounds(rounds: list[dict]) -> dict:
    """One case from several rounds of it (--rounds): each runner's timed samples from every round,
    their median and minimum; counts and checks from the first round.  Rounds interleave the
    runners, so a slow spell of the machine (here 0.2-0.5 s at up to 1.8x) falls on some rounds of
    each rather than on all of one runner's samples."""
    case = rounds[0]
    for later in rounds[1:]:
        for group in ("ours", "peers"):
            for key, result in case[group].items():
                other = later[group].get(key, {})
                if "samples_ms" in result and "samples_ms" in other:
                    result["samples_ms"] = result["samples_ms"] + other["samples_ms"]
    for group in ("ours", "peers"):
        for result in case[group].values():
            if "samples_ms" in result:
                result.update(summary(result["samples_ms"]))
    case["rounds"] = len(rounds)
    return case


def run_case(volume, spec, level, peers, args) -> dict:
    name, gd = spec["volume"], spec["gd"]
    voxels = volume.size
    repeats = repeats_for(voxels, args)
    n0, n1, n2 = volume.shape
    grid = f"{n0}^3" if n0 == n1 == n2 else f"{n0}x{n1}x{n2}"
    lo, hi = float(volume.min()), float(volume.max())
    step = float(np.float32(LEVEL_STEP * (hi - lo)))
    levels = {"a": float(level), "b": float(level) + step}
    case = {"size": n0 if spec.get("synthetic") else list(volume.shape), "grid": grid, "voxels": voxels,
            "volume": name, "level": float(level), "dtype": str(volume.dtype), "gradient_direction": gd,
            "order": "Fortran" if volume.flags.f_contiguous and not volume.flags.c_contiguous else "C",
            "repeats": repeats, "levels": levels, "value_range": [lo, hi], "ours": {}, "peers": {}}
    if not spec.get("synthetic"):
        case["real"] = True
    tag = f"[{grid} {case_name(case)}]"
    log(f"{tag} ours: iso change")
    case["ours"]["iso_change"] = bench_ours_iso_change(volume, gd, levels, repeats, args.warmup)
    log(f"{tag} ours: first (gpu)")
    case["ours"]["first"] = bench_ours_first(volume, gd, levels["a"], repeats, "gpu", args.warmup)
    log(f"{tag} ours: first (gpu), fresh GPU memory each call")
    case["ours"]["first_fresh"] = bench_ours_first(volume, gd, levels["a"], repeats, "gpu", 0, fresh=True)
    if voxels <= CPU_MAX_SIZE ** 3 and not args.no_cpu:
        log(f"{tag} ours: numpy")
        case["ours"]["numpy"] = bench_ours_first(volume, gd, levels["a"], repeats, "cpu", 0)
    log(f"{tag} ours: first, default backend")
    case["ours"]["auto"] = bench_ours_first(volume, gd, levels["a"], repeats, "auto", args.warmup)
    gc.collect()
    for peer in peers:
        if peer.missing is not None:
            case["peers"][peer.key] = {"label": peer.label, "skipped": "not importable"}
            continue
        log(f"{tag} {peer.label}")
        try:
            result = bench_peer(peer, volume, gd, levels, repeats, args.warmup)
        except Exception as exc:  # a peer failing (memory, a bug) must not end the run
            case["peers"][peer.key] = {"label": peer.label, "skipped": f"failed: {type(exc).__name__}: {exc}"}
        else:
            case["peers"][peer.key] = {"label": peer.label, **result}
    gc.collect()
    return case


def case_name(case) -> str:
    """The volume column: a real scan names its level, a synthetic volume is always at 0."""
    return f"{case['volume']} @ {case['level']:g}" if case.get("real") else case["volume"]


def git_state() -> str:
    src = Path(isoscope.__file__).resolve().parent.parent
    try:
        rev = subprocess.run(["git", "-C", str(src), "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(src), "status", "--porcelain", "--", "app", "shaders"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return rev + (" + uncommitted changes to app/ or shaders/" if dirty else "")
    except Exception:
        return "not a git checkout"


class MachineLoad:
    """How much of the machine other processes used during the run (Linux /proc/stat)."""

    def __init__(self):
        self.start = self._sample()

    @staticmethod
    def _sample():
        import resource
        try:
            fields = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
        except (OSError, ValueError):
            return None
        tick = os.sysconf("SC_CLK_TCK")
        user, nice, system, idle, iowait, irq, softirq, steal = (fields + [0] * 8)[:8]
        usage = resource.getrusage(resource.RUSAGE_SELF)
        return {"busy": (user + nice + system + irq + softirq) / tick, "idle": (idle + iowait) / tick,
                "steal": steal / tick, "ours": usage.ru_utime + usage.ru_stime, "wall": time.perf_counter()}

    def describe(self) -> str | None:
        end = self._sample()
        if not (self.start and end):
            return None
        d = {k: end[k] - self.start[k] for k in end}
        others = max(d["busy"] - d["ours"], 0.0) / d["wall"]
        return (f"other processes used {others:.2f} of the {os.cpu_count()} cores on average during the run, "
                f"the hypervisor stole {d['steal'] / d['wall']:.2f}; this process {d['ours'] / d['wall']:.2f}")


# -- report -----------------------------------------------------------------------------------

def fmt_ms(ms) -> str:
    if ms is None:
        return "-"
    return f"{ms:.1f}" if ms < 100 else f"{ms:.0f}"


def fmt_ratio(peer_ms, ours_ms) -> str:
    if peer_ms is None or not ours_ms:
        return "n/a"
    return f"{peer_ms / ours_ms:.2f}"


def fmt_count(n) -> str:
    return "-" if n is None else f"{n:,}"


def markdown(meta, cases, peers, warnings, notes) -> str:
    out = [f"## isoscope extraction benchmark, {meta['date']}", "",
           f"- GL renderer: {meta['renderer']}",
           f"- machine: {meta['cpus']} CPUs, {meta['platform']}; LP_NUM_THREADS={meta['lp_num_threads']}",
           f"- isoscope: {meta['app']} ({meta['git']})",
           "- peers: " + ", ".join(f"{p.label} {p.version}" for p in peers if p.missing is None),
           f"- volumes: FIELD-NOTES definitions (benchmarks/volumes.py), float32; levels 0 and "
           f"0 + {LEVEL_STEP:.1%} of the data range, alternated; sphere with gradient_direction="
           f"\"ascent\", gyroid and noise \"descent\", for us and scikit-image; a real scan "
           f"(`name @ level`, in its file's dtype, \"descent\") at level L and L + {LEVEL_STEP:.1%} of its range",
           f"- checks: every peer's triangle count within {TRIANGLE_TOLERANCE:.0%} of ours at both levels, "
           f"and every mesh's vertices on the level set when read in array-index order (axis order); "
           f"failures are listed at the end",
           "- times: median ms of the repeats; ratio = peer ms / our ms, > 1 means we are faster; "
           "a peer's time is its re-run at the new level (it keeps nothing between levels)",
           ""]
    out += ["### Iso change (resident volume): peer ms / our ms", ""]
    head = ["size", "volume", "triangles", "ours ms"] + [p.label for p in peers]
    gpu_ms = [c["ours"]["iso_change"]["gpu_median_ms"] for c in cases if "gpu_median_ms" in c["ours"]["iso_change"]]
    if any(ms > 0.01 for ms in gpu_ms):
        head.insert(4, "ours GPU ms")
    elif gpu_ms:
        notes = notes + ["GL timer queries (`ex.last_gpu_ms`) read ~0 ms on this renderer, so the GPU ms "
                         "column is left out; the wall times above include waiting for the GPU"]
    out += ["| " + " | ".join(head) + " |", "|" + "---|" * 2 + "---:|" * (len(head) - 2)]
    for c in cases:
        ours = c["ours"]["iso_change"]
        row = [c["grid"], case_name(c), fmt_count(ours["triangles"]["a"]), fmt_ms(ours["median_ms"])]
        if "ours GPU ms" in head:
            row.append(fmt_ms(ours.get("gpu_median_ms")))
        row += [cell_ratio(c["peers"][p.key], ours["median_ms"]) for p in peers]
        out.append("| " + " | ".join(row) + " |")
    out += ["", "### First extraction (upload + extract + read-back): peer ms / our ms", ""]
    head = ["size", "volume", "ours GPU ms", "ours GPU ms, fresh memory", "ours numpy ms"] + [p.label for p in peers]
    out += ["| " + " | ".join(head) + " |", "|" + "---|" * 2 + "---:|" * (len(head) - 2)]
    for c in cases:
        first = c["ours"]["first"]
        numpy_ms = c["ours"]["numpy"]["median_ms"] if "numpy" in c["ours"] else None
        fresh_ms = c["ours"]["first_fresh"]["median_ms"] if "first_fresh" in c["ours"] else None
        row = [c["grid"], case_name(c), fmt_ms(first["median_ms"]), fmt_ms(fresh_ms), fmt_ms(numpy_ms)]
        row += [cell_ratio(c["peers"][p.key], first["median_ms"]) for p in peers]
        out.append("| " + " | ".join(row) + " |")
    out += ["", "### One-shot with the default backend (`isoscope.marching_cubes(volume, level)`): peer ms / our ms",
            ""]
    head = ["size", "volume", "dtype, order", "ours ms"] + [p.label for p in peers]
    out += ["| " + " | ".join(head) + " |", "|" + "---|" * 3 + "---:|" * (len(head) - 3)]
    for c in cases:
        auto = c["ours"]["auto"]
        row = [c["grid"], case_name(c), f"{c['dtype']}, {c['order']}", fmt_ms(auto["median_ms"])]
        row += [cell_ratio(c["peers"][p.key], auto["median_ms"]) for p in peers]
        out.append("| " + " | ".join(row) + " |")
    out += ["", "### Medians (ms) and triangle counts at the first level (0; a real scan's L)", ""]
    head = ["size", "volume", "runner", "median ms", "min ms", "runs", "triangles", "vs ours"]
    out += ["| " + " | ".join(head) + " |", "|---|---|---|---:|---:|---:|---:|---:|"]
    for c in cases:
        ours_n = c["ours"]["iso_change"]["triangles"]["a"]
        rows = [("ours: iso change (Extractor.extract)", c["ours"]["iso_change"]),
                ("ours: first, GPU (isoscope.marching_cubes)", c["ours"]["first"]),
                ("ours: first, GPU, fresh memory (release_gpu_memory() before each)", c["ours"].get("first_fresh")),
                ("ours: first, numpy reference", c["ours"].get("numpy"))]
        rows += [(p.label, c["peers"][p.key]) for p in peers]
        for label, r in rows:
            if r is None:
                continue
            if "median_ms" not in r:
                out.append(f"| {c['grid']} | {case_name(c)} | {label} | - | - | - | - | {r['skipped']} |")
                continue
            n = r["triangles"]["a"]
            delta = f"{100.0 * (n - ours_n) / ours_n:+.2f}%" if ours_n else "-"
            out.append(f"| {c['grid']} | {case_name(c)} | {label} | {fmt_ms(r['median_ms'])} | "
                       f"{fmt_ms(r['min_ms'])} | {len(r['samples_ms'])} | {fmt_count(n)} | {delta} |")
    out += ["", "### Our GPU scratch (beyond the volume texture and the mesh)", ""]
    out += ["| size | volume | peak scratch MiB | bytes per voxel | bricks cut by the level |",
            "|---|---|---:|---:|---:|"]
    for c in cases:
        ours = c["ours"]["iso_change"]
        scratch = ours["scratch_bytes"]
        share = f"{ours['active_brick_share']:.1%}" if "active_brick_share" in ours else "-"
        out.append(f"| {c['grid']} | {case_name(c)} | {scratch / 2**20:.2f} | {scratch / c['voxels']:.3f} "
                   f"| {share} |")
    if notes or warnings:
        out.append("")
    out += [f"- note: {n}" for n in notes]
    out += [f"- WARNING: {w}" for w in warnings]
    return "\n".join(out) + "\n"


def cell_ratio(result, ours_ms) -> str:
    if "median_ms" not in result:
        return "skipped"
    return fmt_ratio(result["median_ms"], ours_ms)


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="Default: 128^3 and 256^3, three volumes, every peer.")
    parser.add_argument("--sizes", default="128,256",
                        help="comma-separated edge lengths (default 128,256)")
    parser.add_argument("--volumes", default=",".join(VOLUMES),
                        help=f"comma-separated: synthetic {','.join(VOLUMES)} (run at every --sizes), real scans "
                             f"{','.join(REAL_VOLUMES)} (their own size and levels), or volume files "
                             f"(NIfTI, NRRD, .npy: at 25/50/75%% of their range)")
    parser.add_argument("--levels", default="",
                        help="comma-separated levels for the real scans and files, in their own units")
    parser.add_argument("--big", action="store_true",
                        help="also the 512^3 sphere (about 2.5 GB of RAM, minutes on llvmpipe)")
    parser.add_argument("--repeats", type=int, default=0,
                        help="timed runs per measurement (default 5 up to 128^3, 3 above)")
    parser.add_argument("--warmup", type=int, default=2,
                        help="untimed runs before the timed ones, per runner and volume (default 2; "
                             "the numpy reference gets none); 0 also skips the settling time and the "
                             "busy second that wakes the CPUs: for a quick check, not for numbers")
    parser.add_argument("--rounds", type=int, default=1,
                        help="measure each case this many times over, every runner in turn, and pool "
                             "each runner's samples (default 1; 3 or more on a noisy machine)")
    parser.add_argument("--float32", action="store_true",
                        help="give every runner the real scans and files as float32 (default: their file's dtype)")
    parser.add_argument("--no-cpu", action="store_true", help="skip our numpy reference")
    parser.add_argument("--as-given", action="store_true",
                        help="give every runner the real scans and files as nibabel returns them (Fortran order), "
                             "not C-ordered; VTK wraps them without a copy")
    parser.add_argument("--cache", default=str(Path(__import__("tempfile").gettempdir()) / "isoscope-bench"),
                        help="where the ct-torso volume is written once as NIfTI (about 200 MB)")
    parser.add_argument("--json", metavar="PATH", help="also write every sample and count as JSON")
    args = parser.parse_args(argv)
    try:
        args.sizes = [int(s) for s in args.sizes.split(",") if s.strip()]
    except ValueError:
        parser.error(f"--sizes wants integers like 128,256, not {args.sizes!r}")
    if any(s < 8 for s in args.sizes):
        parser.error("--sizes: every size must be at least 8")
    args.volumes = [v.strip() for v in args.volumes.split(",") if v.strip()]
    unknown = sorted(v for v in args.volumes
                     if v not in VOLUMES and v not in REAL_VOLUMES and v != "ct-torso" and not Path(v).is_file())
    if unknown:
        parser.error(f"--volumes: unknown {', '.join(unknown)}; choose from "
                     f"{', '.join([*VOLUMES, *REAL_VOLUMES, 'ct-torso'])} or name an existing volume file")
    if "ct-torso" in args.volumes:
        Path(args.cache).mkdir(parents=True, exist_ok=True)
    try:
        args.levels = [float(v) for v in args.levels.split(",") if v.strip()]
    except ValueError:
        parser.error(f"--levels wants numbers like 60,128, not {args.levels!r}")
    if args.repeats < 0 or args.warmup < 0:
        parser.error("--repeats and --warmup cannot be negative")
    if args.rounds < 1:
        parser.error("--rounds must be 1 or more")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    peers = make_peers()
    notes = [f"{p.label} skipped: not importable ({p.missing}); `pip install -e .[bench]` installs it"
             for p in peers if p.missing is not None]
    for n in notes:
        log(n)
    started, load = time.perf_counter(), MachineLoad()
    renderer = warm_up(peers, busy_seconds=1.0 if args.warmup else 0.0)
    meta = {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "renderer": renderer, "cpus": os.cpu_count(), "platform": platform.platform(),
            "lp_num_threads": os.environ.get("LP_NUM_THREADS", "unset"),
            "app": str(Path(isoscope.__file__).resolve().parent), "git": git_state(),
            "python": platform.python_version(), "numpy": np.__version__,
            "peers": {p.key: (p.version if p.missing is None else None) for p in peers}}
    cases, warnings = [], []
    if args.rounds > 1:
        notes.append(f"each case measured in {args.rounds} rounds, every runner in turn in each; medians and "
                     "minima over all rounds' samples")
    for spec in plan(args):
        try:
            spec_cases = run_cases(spec, peers, args)
        except MissingVolume as exc:
            log(f"skipped: {exc}")
            notes.append(f"skipped: {exc}")
            continue
        for case in spec_cases:
            case_warnings = check_case(case)
            for w in case_warnings:
                log("WARNING:", w)
            warnings += case_warnings
            cases.append(case)
    for c in cases:
        for r in c["peers"].values():
            if r.get("skipped", "").startswith("failed"):
                notes.append(f"{r['label']} at {c['grid']} {case_name(c)}: {r['skipped']}")
    meta["seconds"] = round(time.perf_counter() - started, 1)
    notes.append(f"whole run: {meta['seconds']:.0f} s")
    meta["load"] = load.describe()
    if meta["load"]:
        notes.append(meta["load"] + " (a busy second core slows VTK's 2 threads and llvmpipe's alike)")
    print(markdown(meta, cases, peers, warnings, notes), end="", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps({"meta": meta, "cases": cases, "warnings": warnings,
                                               "notes": notes}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
