#!/usr/bin/env python3
"""Big volumes: chunked extraction of a generated N^3 uint8 Zarr, on 1 process and on dask workers.

Generates (once; kept in --dir) a gyroid of period --period voxels as a uint8 Zarr (v3,
128^3 chunks, zstd), value 128 + 100 * gyroid, level 128 (rounding gives exact ties).
Then, each run in a fresh subprocess so its peak resident memory is its own:

- chunked:   one process: open the Zarr (lazy; the value range is one scan), extract box by
             box in one GL context, merge, write a binary PLY - what `isoscope export
             big.zarr --chunk C` does;
- dask N:    the same on a LocalCluster of N worker processes (1 thread each, own EGL context);
             the cluster's start-up is not timed; peak memory per worker from the workers;
- vtk:       the whole array read into memory, vtkFlyingEdges3D (2 threads), no file written.

Prints a markdown table (stdout); progress to stderr.  Not a test: nothing fails when slow.
    python benchmarks/bench_big.py                 # 1024^3 (1 GiB), about 10 min on 2-core llvmpipe
    python benchmarks/bench_big.py --size 512      # quicker
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

CHILD = r"""
import json, resource, sys, time
import numpy as np
mode, path, level, chunk, out = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
workers = int(mode[4:]) if mode.startswith("dask") else 0
result = {}
def peak_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
if mode == "vtk":
    import zarr
    from vtkmodules.util import numpy_support
    from vtkmodules.vtkCommonCore import vtkSMPTools
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkFiltersCore import vtkFlyingEdges3D
    start = time.perf_counter()
    volume = np.ascontiguousarray(zarr.open(path, mode="r")[...])
    result["read_s"] = time.perf_counter() - start
    smp = vtkSMPTools(); smp.SetBackend("STDThread"); smp.Initialize(2)
    image = vtkImageData(); image.SetDimensions(*volume.shape[::-1])
    image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(volume.reshape(-1), deep=False))
    fe = vtkFlyingEdges3D(); fe.SetInputData(image); fe.SetValue(0, level)
    start = time.perf_counter(); fe.Update(); result["extract_s"] = time.perf_counter() - start
    result["triangles"] = fe.GetOutput().GetNumberOfPolys()
    result["total_s"] = result["read_s"] + result["extract_s"]
else:
    from isoscope.big.chunked import marching_cubes_chunked
    from isoscope.io.export import write_mesh
    from isoscope.volumes import open_volume
    client = None
    if workers:
        import logging
        from dask.distributed import Client, LocalCluster
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR)
        client = Client(cluster)
    start = time.perf_counter()
    volume = open_volume(path)
    result["open_s"] = time.perf_counter() - start
    t = time.perf_counter()
    if workers:
        from isoscope.big.cluster import marching_cubes_on_cluster
        verts, faces, normals, _ = marching_cubes_on_cluster(volume.data, level, volume.spacing, True, chunk,
                                                             scheduler=cluster.scheduler_address)
        result["worker_peak_mib"] = sorted(v / 1024 for v in client.run(
            lambda: __import__("resource").getrusage(__import__("resource").RUSAGE_SELF).ru_maxrss).values())
    else:
        verts, faces, normals, _ = marching_cubes_chunked(volume.data, level, volume.spacing, True, chunk)
    result["extract_s"] = time.perf_counter() - t
    result["peak_before_write_mib"] = peak_mib()
    t = time.perf_counter()
    write_mesh(out, verts, faces, normals)
    result["write_s"] = time.perf_counter() - t
    result["total_s"] = time.perf_counter() - start
    result["triangles"] = len(faces)
    if client is not None:
        client.close(); cluster.close()
result["peak_mib"] = peak_mib()
print(json.dumps(result))
"""


def log(*parts) -> None:
    print(*parts, file=sys.stderr, flush=True)


def make_volume(path: Path, n: int, period: float) -> float:
    """The gyroid Zarr at `path` (kept when it exists with the same size and period); seconds spent."""
    import zarr
    if (path / "zarr.json").is_file():
        existing = zarr.open(str(path), mode="r")
        if existing.shape == (n, n, n) and existing.attrs.get("period") == period:
            return 0.0
    start = time.perf_counter()
    array = zarr.create_array(str(path), shape=(n, n, n), chunks=(128, 128, 128), dtype="u1", overwrite=True)
    phase = (np.arange(n, dtype=np.float32) * np.float32(2 * np.pi / period))
    s, c = np.sin(phase), np.cos(phase)
    slab = 128
    for i0 in range(0, n, slab):
        si, ci = s[i0:i0 + slab, None, None], c[i0:i0 + slab, None, None]
        gyroid = si * c[None, :, None] + s[None, :, None] * c[None, None, :] + s[None, None, :] * ci
        array[i0:i0 + slab] = np.clip(np.rint(128 + 100 * gyroid / 1.5), 0, 255).astype(np.uint8)
        log(f"  wrote planes {i0 + len(si)}/{n}")
    array.attrs["period"] = period
    return time.perf_counter() - start


def run(mode: str, path: Path, level: float, chunk: int, out: Path) -> dict:
    log(f"running {mode} ...")
    done = subprocess.run([sys.executable, "-c", CHILD, mode, str(path), str(level), str(chunk), str(out)],
                          capture_output=True, text=True)
    if done.returncode:
        log(done.stderr[-2000:])
        return {"error": done.stderr.strip().splitlines()[-1] if done.stderr.strip() else f"exit {done.returncode}"}
    result = json.loads(done.stdout.strip().splitlines()[-1])
    log(f"  {result}")
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=1024, help="samples per axis (default 1024: 1 GiB of uint8)")
    parser.add_argument("--period", type=float, default=256.0, help="gyroid period in voxels (default 256)")
    parser.add_argument("--chunk", type=int, default=128, help="cells per box and axis (default 128)")
    parser.add_argument("--dir", type=Path, default=Path("/tmp/isoscope-bench-big"), help="where the Zarr is kept")
    parser.add_argument("--modes", default="chunked,dask1,dask2,vtk", help="comma-separated runs")
    args = parser.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)
    path = args.dir / f"gyroid{args.size}.zarr"
    log(f"volume {path}")
    made = make_volume(path, args.size, args.period)
    rows = {mode: run(mode, path, 128.0, args.chunk, args.dir / f"{mode}.ply") for mode in args.modes.split(",")}
    n = args.size
    print(f"{n}^3 uint8 gyroid (period {args.period:g}), Zarr 128^3 chunks, level 128, boxes of {args.chunk}^3 "
          f"cells{f'; generated in {made:.0f} s' if made else ''}\n")
    print("| run | open s | extract s | write s | total s | triangles | peak RSS MiB (main) | per worker MiB |")
    print("|---|---:|---:|---:|---:|---:|---:|---|")
    for mode, r in rows.items():
        if "error" in r:
            print(f"| {mode} | failed: {r['error']} |||||||")
            continue
        cells = [f"{r[key]:.1f}" if key in r else "-" for key in ("open_s", "extract_s", "write_s", "total_s")]
        if "read_s" in r:
            cells[0] = f"{r['read_s']:.1f} (read whole)"
        workers = ", ".join(f"{v:.0f}" for v in r.get("worker_peak_mib", [])) or "-"
        print(f"| {mode} | {' | '.join(cells)} | {r['triangles']:,} | {r['peak_mib']:.0f} | {workers} |")
    if "error" not in rows.get("dask1", {"error": 1}) and "error" not in rows.get("dask2", {"error": 1}):
        print(f"\nspeed-up 1 -> 2 workers (extract): {rows['dask1']['extract_s'] / rows['dask2']['extract_s']:.2f}x")
    same = [m for m in ("chunked", "dask1", "dask2") if (args.dir / f"{m}.ply").is_file() and m in rows]
    if len(same) > 1:
        first = (args.dir / f"{same[0]}.ply").read_bytes()
        print(f"PLY files identical across {', '.join(same)}: "
              f"{all((args.dir / f'{m}.ply').read_bytes() == first for m in same[1:])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
