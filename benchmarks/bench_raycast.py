"""Frame time of direct volume rendering (ray casting, gfx/raycast.py) against the mesh of the same view.

    python benchmarks/bench_raycast.py [--size 1280x800] [--frames 8] [--volumes mri ct] [--modes mesh dvr ...]
                                       [--with-surfaces] [--memory-budget 64M]

Each mode (mip, minip, mean, iso, dvr) and the plain mesh drawn by the headless viewer (the `render`
path: the same shaders as the window) with the camera turning a little every frame, so no frame repeats
the last, at rest and as the window draws while the view moves (a ray per 2x2, 3x3 or 4x4 pixels as the
frame times measured say, stretched, and a step twice as long, model/raycast.py): the
median and 90th percentile of whole frames (drawing and reading back the pixels), after one warm-up frame
that uploads the volume and compiles the mode's program.  Volumes: the MNI T1 template
(nilearn's wheel ships it: 197x233x189 uint8) and the 512x512x400 int16 CT-like torso of volumes.py.
The issue's aim: < 100 ms a frame while moving on llvmpipe, < 5 ms on a GPU.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from volumes import ct_torso, load_real

MODES = (None, "mip", "minip", "mean", "iso", "dvr")


def frames(viewer, mode: str | None, count: int, moving: bool = False) -> tuple[list[float], list[float]]:
    """Frame times in ms, wall clock and CPU (all the process's threads: llvmpipe's too, so on a shared machine
    the work a frame takes, whatever else runs); `moving`: as the window draws while the view moves (a ray
    per N x N pixels, N from 2 to 4 as the frames measured need: each frame's time handed to the next follow,
    as the window's loop does)."""
    viewer.state.set_raycast(mode)
    viewer.render()   # warm-up: the texture, the program, the mesh
    times, cpu = [], []
    for _ in range(count):
        viewer.camera.azimuth += 3.0
        start, start_cpu = time.perf_counter(), time.process_time()
        if moving:
            viewer.app.follow(times[-1] / 1000 if times else 0.0)
            viewer.target.use()
            viewer.app.draw(viewer.target.viewport, moving=True)
            viewer.target.read_rgb()
        else:
            viewer.render()
        times.append((time.perf_counter() - start) * 1000)
        cpu.append((time.process_time() - start_cpu) * 1000)
    return times, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="1280x800")
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--volumes", nargs="+", default=["mri", "ct"], choices=["mri", "ct"])
    parser.add_argument("--modes", nargs="+", default=[mode or "mesh" for mode in MODES],
                        choices=[mode or "mesh" for mode in MODES])
    parser.add_argument("--with-surfaces", action="store_true", help="the level's surface drawn with the rays")
    parser.add_argument("--memory-budget", default=None,
                        help="e.g. 64M: a volume over it is ray cast in bricks (its bricks in view read in full)")
    args = parser.parse_args()
    size = tuple(int(n) for n in args.size.split("x"))
    from isoscope.viewer.model.raycast import rays_note
    from isoscope.viewer.ui.headless import HeadlessViewer
    from isoscope.volumes.inputs import as_volume
    for name in args.volumes:
        if name == "mri":
            data, spacing = load_real("mni-t1")
            level = 80.0
        else:
            data, spacing = ct_torso(), (0.8, 0.8, 1.0)
            level = 300.0
        viewer = HeadlessViewer(size, previews=True, memory_budget=args.memory_budget)   # the window's frames
        try:
            viewer.show(as_volume(data, spacing=spacing), level)
            if args.with_surfaces:
                viewer.state.set_with_surfaces(True)
            renderer = viewer.ctx.info["GL_RENDERER"]
            print(f"{name}: {'x'.join(map(str, data.shape))} {data.dtype}, {args.size}, {renderer}")
            for mode in (None if name == "mesh" else name for name in args.modes):
                times, cpu = frames(viewer, mode, args.frames)
                moving, moving_cpu = frames(viewer, mode, args.frames, moving=True) if mode else (times, cpu)
                print(f"  {mode or 'mesh':6s} at rest median {np.median(times):8.1f} ms, p90 "
                      f"{np.percentile(times, 90):8.1f}, cpu {np.median(cpu):8.1f};  moving median "
                      f"{np.median(moving):8.1f} ms, p90 {np.percentile(moving, 90):8.1f}, "
                      f"cpu {np.median(moving_cpu):8.1f}"
                      + (f", a ray per {viewer.app.rays.spacing}x{viewer.app.rays.spacing} pixels" if mode else ""))
                note = rays_note(viewer.state)
                if note:
                    print(f"         {note}")
        finally:
            viewer.release()


if __name__ == "__main__":
    main()
