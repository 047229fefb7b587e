"""Frame time of the real viewer window while the iso slider is dragged (the target: < 50 ms on llvmpipe).

    python benchmarks/bench_viewer.py [--volume metaballs | --memmap 1024 | --pyramid 1024] [--frames 60]
                                      [--size 1280x800]
                                      [--slice z=40 ...] [--surfaces 2] [--opacity 0.4] [--memory-budget SIZE]

Opens the viewer's window (under a private Xvfb when there is no DISPLAY), then
moves the iso value on every frame, as a slider drag does, and times whole
frames: re-extraction, drawing, the imgui panel and the buffer swap.  Then the value
rests: the frames until the full-resolution mesh has been drawn once are timed
(the time to full resolution after rest), and the process's peak RSS is reported.  Past the memory budget
(--memory-budget small enough) the frames then go on until every brick in view is at full resolution
(model/bricks.py): how long that took and how long the frames meanwhile were.  With --surfaces N, N-1
more levels stay on show (below the dragged range, at --opacity) while the first is dragged.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np


@contextmanager
def display():
    """The current X display, or a private Xvfb for the run."""
    if os.environ.get("DISPLAY"):
        yield os.environ["DISPLAY"]
        return
    if shutil.which("Xvfb") is None:
        sys.exit("bench_viewer: no DISPLAY and no Xvfb; install xvfb or run on a desktop")
    read_end, write_end = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write_end), "-screen", "0", "1920x1080x24",
                               "-nolisten", "tcp", "-noreset"], pass_fds=(write_end,),
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_end)
    with os.fdopen(read_end) as ready:
        number = ready.readline().strip()
    os.environ["DISPLAY"] = f":{number}"
    try:
        yield os.environ["DISPLAY"]
    finally:
        server.terminate()
        server.wait(timeout=30)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volume", default=None, help="a volume spec (default: the viewer's default)")
    parser.add_argument("--memmap", type=int, default=None, metavar="N",
                        help="drag an N^3 uint8 memory-mapped .npy instead (volumes.smooth_memmap, made once in "
                             "--dir)")
    parser.add_argument("--pyramid", type=int, default=None, metavar="N",
                        help="drag --memmap N's volume as an OME-Zarr image with 2x2x2-mean levels instead "
                             "(volumes.smooth_pyramid, made once in --dir): past the budget, one of its levels "
                             "is the coarse view and the bricks come from the full one")
    parser.add_argument("--dir", default="/tmp/isoscope-bench", help="where --memmap's and --pyramid's volumes "
                                                                      "are kept")
    parser.add_argument("--frames", type=int, default=60, help="frames of dragging to time")
    parser.add_argument("--size", default="1280x800", help="window size WxH")
    parser.add_argument("--slice", action="append", default=[], metavar="AXIS=INDEX",
                        help="show this slice (with its isocurve and the 2-D view) while dragging; repeatable")
    parser.add_argument("--surfaces", type=int, default=1, help="levels on show, 1..4 (the first is dragged)")
    parser.add_argument("--opacity", type=float, default=1.0,
                        help="opacity of the levels not dragged (below 1: drawn by weighted blended OIT)")
    parser.add_argument("--memory-budget", default=None, metavar="SIZE",
                        help="the viewer's memory budget (default: this GL's, half the free RAM on llvmpipe)")
    parser.add_argument("--gl41", action="store_true",
                        help="imitate macOS on Mesa (MESA_GL_VERSION_OVERRIDE=4.1): an OpenGL 4.1 window, meshes made "
                             "by the CPU extractor")
    args = parser.parse_args(argv)
    if args.gl41:   # before the first GL context: Mesa reads them once
        os.environ.update(MESA_GL_VERSION_OVERRIDE="4.1", MESA_GLSL_VERSION_OVERRIDE="410")
    from isoscope.cli.slice_options import slice_spec
    slices = [slice_spec(text) for text in args.slice]
    width, height = (int(v) for v in args.size.lower().split("x"))

    with display():
        from isoscope.core.budget import requested_budget, using_budget
        from isoscope.viewer.model.recent import RecentFiles
        from isoscope.viewer.ui.window import ViewerWindow
        from isoscope.volumes import DEFAULT_VOLUME, open_volume
        if args.memmap or args.pyramid:
            sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
            from volumes import smooth_memmap, smooth_pyramid
            made = smooth_pyramid(args.dir, args.pyramid) if args.pyramid else smooth_memmap(args.dir, args.memmap)
            args.volume = str(made)
        before_window = rss_parts()   # imports done, no GL yet: what the window and the volume add is above it
        opened = time.perf_counter()
        # --memmap: mapped whatever its size (a 512^3 .npy, 128 MiB, would otherwise be read whole into RSS)
        volume = open_volume(args.volume or DEFAULT_VOLUME, map_files=bool(args.memmap))
        with using_budget(requested_budget(args.memory_budget)):
            window = ViewerWindow(volume, size=(width, height), recent=RecentFiles(None))
        open_s = time.perf_counter() - opened
        try:
            state, scene = window.state, window.scene
            if state.volume is None:
                sys.exit(f"bench_viewer: the window did not show {volume.name}: {state.error}")
            for axis, index in slices:
                try:
                    state.slices.show(axis, True, index)
                except ValueError as exc:
                    sys.exit(f"bench_viewer: {exc}")
            low, high = state.value_range
            for k in range(1, args.surfaces):   # outer shells (on a density) around the dragged level
                state.levels.add(low + (high - low) * (0.25 - 0.05 * k))
                state.levels.set_opacity(k, args.opacity)
            state.levels.select(0)
            for _ in range(5):  # JIT of every shader and first buffer allocations
                window.draw_frame()
            low, high = state.value_range
            frame_ms, extract_ms, triangles, steps = [], [], [], []
            for frame in range(args.frames):
                # A drag across the middle of the range and back, one step per frame.
                phase = frame / max(args.frames - 1, 1)
                state.iso = low + (high - low) * (0.3 + 0.4 * (1 - abs(2 * phase - 1)))
                start = time.perf_counter()
                window.draw_frame()
                frame_ms.append((time.perf_counter() - start) * 1000)
                extract_ms.append(scene.stats.extract_ms)
                triangles.append(sum(mesh.n_triangles for mesh in scene.stats.meshes))
                steps.append(scene.stats.preview_step)
            # The value rests: frames go on until the full-resolution mesh is back on show.
            released = time.perf_counter()
            rest_ms = []   # each frame after the last move, until the full mesh has been drawn once
            while scene.stats.preview_step > 1 and time.perf_counter() - released < 30.0:
                start = time.perf_counter()
                window.draw_frame()
                rest_ms.append((time.perf_counter() - start) * 1000)
            full_after_ms = (time.perf_counter() - released) * 1000
            start = time.perf_counter()
            window.draw_frame()   # a frame at rest drawing the full mesh
            full_frame_ms = (time.perf_counter() - start) * 1000
            shape = "x".join(map(str, volume.data.shape))
            shown = ", ".join(args.slice) or "none"
            print(f"viewer frame while dragging the iso slider: {volume.name} {shape}, "
                  f"window {width}x{height}, slices {shown}, {state.gl_renderer}, {len(state.levels)} surface(s)"
                  + (f", the others at opacity {args.opacity:g}" if len(state.levels) > 1 else ""))
            print("  frames ms  ", " ".join(f"{ms:.0f}" for ms in frame_ms), "steps", steps)
            print(f"  frame       median {np.median(frame_ms):.1f} ms, "
                  f"90th percentile {np.percentile(frame_ms, 90):.1f} ms over {args.frames} frames")
            print(f"  extraction  median {np.median(extract_ms):.1f} ms; "
                  f"triangles drawn {min(triangles):,} .. {max(triangles):,}")
            previews = [s for s in steps if s > 1]
            print(f"  preview     {len(previews)} of {args.frames} frames drew a coarse preview"
                  + (f" (sample step {min(previews)}..{max(previews)})" if previews else "")
                  + f"; full mesh back {full_after_ms:.0f} ms after the last move (frames "
                  + " ".join(f"{ms:.0f}" for ms in rest_ms) + f"; its extraction {scene.stats.extract_ms:.0f} ms), "
                  f"a frame of it at rest {full_frame_ms:.0f} ms")
            bricks = state.bricks
            import resource
            if bricks is not None:   # past the budget: frames go on until what the room holds is refined
                before_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
                refined_at = time.perf_counter()
                brick_ms, follow_ms = [], []
                follow = scene.follow_bricks

                def timed_follow():
                    start = time.perf_counter()
                    follow()
                    follow_ms.append((time.perf_counter() - start) * 1000)
                scene.follow_bricks = timed_follow   # the buffers' share of each frame
                window.draw_frame()
                while not (bricks.full_in_view or bricks.settled) and time.perf_counter() - refined_at < 600.0:
                    start = time.perf_counter()
                    window.draw_frame()
                    brick_ms.append((time.perf_counter() - start) * 1000)
                refined_s = time.perf_counter() - refined_at
                start = time.perf_counter()
                window.draw_frame()
                settled_ms = (time.perf_counter() - start) * 1000
                drawn = sum(mesh.n_triangles for mesh in scene.stats.meshes)
                print(f"  bricks      {bricks.text} (layout: step {bricks.layout.step}, {bricks.layout.cells}^3 "
                      f"bricks, {bricks.layout.room / 2**20:.1f} MiB for their meshes) {refined_s:.1f} s after "
                      f"the full coarse mesh; frames meanwhile median {np.median(brick_ms or [0]):.0f} ms, 90th "
                      f"percentile {np.percentile(brick_ms or [0], 90):.0f} ms, max {max(brick_ms or [0]):.0f} ms "
                      f"over {len(brick_ms)} (the buffers' part median {np.median(follow_ms):.1f} ms, max "
                      f"{max(follow_ms):.0f} ms); then a frame {settled_ms:.0f} ms drawing {drawn:,} triangles; "
                      f"peak RSS {before_mib:.0f} MiB before the bricks")
            peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            print(f"  shown       {'x'.join(map(str, scene.stats.shown_shape))} of {shape} at rest (memory budget "
                  f"{state.budget.text}), {volume.data.dtype}; window open with the first mesh in {open_s:.1f} s; "
                  f"peak RSS {peak:.0f} MiB; now {rss_parts()} (before the window: {before_window})")
        finally:
            window.close()
    return 0


def rss_parts() -> str:
    """The process's resident memory now, by kind (Linux /proc/self/status): its own (anonymous: arrays,
    buffers, the GL driver's), the pages of files it maps (a memory-mapped volume's samples read: the page
    cache, given back under pressure) and shared memory."""
    try:
        fields = dict(line.split(":", 1) for line in Path("/proc/self/status").read_text().splitlines() if ":" in line)
        parts = [(name, int(fields[key].split()[0]) / 1024) for name, key in
                 (("anonymous", "RssAnon"), ("mapped files", "RssFile"), ("shared", "RssShmem"))]
    except (OSError, KeyError, ValueError):
        return "RSS by kind not known here"
    return "RSS " + ", ".join(f"{name} {mib:.0f} MiB" for name, mib in parts)


if __name__ == "__main__":
    sys.exit(main())
