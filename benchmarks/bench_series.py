"""Playback of a series in the real viewer window: time points shown per second (issue 27's target: >= 10 on
llvmpipe for MNI-sized volumes).

    python benchmarks/bench_series.py [--volume mni-t1] [--times 10] [--points 40] [--size 1280x800]
                                      [--format npy|nii] [--level 128] [--surfaces 1] [--full]

Writes a series of `--times` time points of the volume (the MNI T1 moved a few voxels along x per time point,
so every mesh differs) as a glob of .npy files or a 4-D .nii, opens it in the viewer's window (under a
private Xvfb when there is no DISPLAY, as bench_viewer.py), presses Play at the highest frame rate the
panel offers (so the reads, uploads and extractions set the pace, not the clock) and counts the time
points put on show over `--points` of them: each read on the worker while the one before shows, uploaded,
extracted (a coarse preview while playing, as while dragging; `--full` holds playback to full-resolution
meshes) and drawn.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_viewer import display  # noqa: E402

from volumes import VOLUMES, load_real  # noqa: E402


def write_series(folder: Path, name: str, times: int, kind: str, resolution: int = 160) -> str:
    """The series' spec: a glob of .npy files or one 4-D .nii."""
    if name in VOLUMES:
        data, spacing = VOLUMES[name][0](resolution), (1.0, 1.0, 1.0)
    else:
        data, spacing = load_real(name)
    frames = [np.roll(data, 3 * t, axis=0) for t in range(times)]
    if kind == "npy":
        for t, frame in enumerate(frames):
            np.save(folder / f"{name}_{t:03d}.npy", frame)
        return str(folder / f"{name}_*.npy")
    import nibabel
    image = nibabel.Nifti1Image(np.stack(frames, axis=-1), np.diag([*spacing, 1.0]))
    path = folder / f"{name}_4d.nii"
    nibabel.save(image, path)
    return str(path)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", default="mni-t1", help="mni-t1, mni-gm, or a synthetic one (sphere, gyroid, noise)")
    parser.add_argument("--resolution", type=int, default=160, help="a synthetic volume's samples per axis")
    parser.add_argument("--times", type=int, default=10, help="time points in the series")
    parser.add_argument("--points", type=int, default=40, help="time points to time (playback loops round)")
    parser.add_argument("--size", default="1280x800", help="window size WxH")
    parser.add_argument("--format", choices=("npy", "nii"), default="npy", help="a glob of .npy files or a 4-D .nii")
    parser.add_argument("--level", type=float, default=None, help="iso level (default: the volume's middle)")
    parser.add_argument("--surfaces", type=int, default=1, help="levels on show, 1..4")
    parser.add_argument("--full", action="store_true", help="full-resolution meshes while playing (no previews)")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))
    with tempfile.TemporaryDirectory(prefix="bench_series_") as folder, display():
        spec = write_series(Path(folder), args.volume, args.times, args.format, args.resolution)
        from isoscope.viewer.model.recent import RecentFiles
        from isoscope.viewer.ui.window import ViewerWindow
        from isoscope.volumes import open_volume

        volume = open_volume(spec)
        window = ViewerWindow(volume, args.level, size=(width, height), recent=RecentFiles(None))
        try:
            state, scene, series = window.state, window.scene, window.state.series
            low, high = state.value_range
            for k in range(1, args.surfaces):
                state.levels.add(low + (high - low) * (0.25 + 0.1 * k))
            state.levels.select(0)
            if args.full:
                scene.previews = False
            for _ in range(5):   # shaders compiled, buffers made
                window.draw_frame()
            idle_ms = []
            for _ in range(10):   # the same time point: what a frame costs without reading, uploading, extracting
                before = time.perf_counter()
                window.draw_frame()
                idle_ms.append((time.perf_counter() - before) * 1000)
            series.set_fps(60)
            series.toggle_play()
            shown, frames, triangles = series.shown, 0, []
            changes, frame_ms = [], []
            start = last = time.perf_counter()
            while len(changes) < args.points:
                before = time.perf_counter()
                window.draw_frame()
                now = time.perf_counter()
                frame_ms.append((now - before) * 1000)
                frames += 1
                if series.shown != shown:
                    shown = series.shown
                    changes.append(now - last)
                    last = now
                    triangles.append(sum(mesh.n_triangles for mesh in scene.stats.meshes))
                if state.error:
                    sys.exit(f"bench_series: {state.error}")
            elapsed = time.perf_counter() - start
            shape = "x".join(map(str, volume.data.shape))
            print(f"series playback: {args.volume} {shape} {volume.data.dtype}, {args.times} time points as "
                  f"{args.format}, window {width}x{height}, {state.gl_renderer}, {len(state.levels)} surface(s), "
                  f"{'full meshes' if args.full else 'previews while playing'}")
            print(f"  time points shown  {args.points / elapsed:.1f} per second ({args.points} in {elapsed:.2f} s); "
                  f"between two: median {1000 * np.median(changes):.0f} ms, "
                  f"90th percentile {1000 * np.percentile(changes, 90):.0f} ms")
            print(f"  frames drawn       {frames} ({frames / elapsed:.1f} per second), "
                  f"median {np.median(frame_ms):.1f} ms; triangles drawn {min(triangles):,} .. {max(triangles):,}")
            print(f"  a frame at rest    median {np.median(idle_ms):.1f} ms (the full mesh, no time moving)")
        finally:
            window.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
