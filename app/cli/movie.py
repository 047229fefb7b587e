"""`isoscope movie`: a turntable, an iso sweep or a series' time points, rendered offscreen as `render`
draws them, written as an H.264 MP4 (imageio through imageio-ffmpeg's ffmpeg), a GIF (Pillow) or a
folder of numbered PNGs.  The file appears whole or not at all (written beside, then renamed)."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..io.movie import movie_kind
from .arguments import OneLineParser, add_render_options
from .common import check_label_options, checked_levels, count_line, progress, wrote
from .slice_options import apply_slice_arguments
from .volume_options import TimeRange, add_volume_arguments, open_volume_from_args

MAX_FRAMES = 10_000


def movie_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog="isoscope movie",
                          description="Render a movie offscreen: a turntable around the vertical axis, an iso sweep "
                                      "or a series' time points, to .mp4 (H.264), .gif or a folder of PNGs.")
    add_render_options(parser, out_help="the movie: NAME.mp4, NAME.gif, or a folder (ending in /) for "
                                        "frame_0000.png, ...", out_metavar="MOVIE")
    motion = parser.add_mutually_exclusive_group()
    motion.add_argument("--turntable", type=_positive, metavar="N",
                        help="N frames once around the vertical axis, from --azimuth (the default motion: 72)")
    motion.add_argument("--sweep", type=_sweep, metavar="A:B",
                        help="the iso value from A to B over --frames frames (a negative A: --sweep=-0.5:0.5)")
    parser.add_argument("--frames", type=_positive, metavar="N", help="frames of a sweep (default 60)")
    parser.add_argument("--fps", type=float, default=24.0, metavar="F", help="frames per second (default 24)")
    add_volume_arguments(parser)
    return parser


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if not 1 <= value <= MAX_FRAMES:
        raise argparse.ArgumentTypeError(f"{value} frames: give 1 to {MAX_FRAMES:,}")
    return value


def _sweep(text: str) -> tuple[float, float]:
    start, colon, stop = text.partition(":")
    try:
        a, b = float(start), float(stop)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--sweep {text!r} is not A:B, two iso values") from None
    if not colon or not (math.isfinite(a) and math.isfinite(b)) or a == b:
        raise argparse.ArgumentTypeError(f"--sweep {text!r}: give two different finite iso values, A:B")
    return a, b


def run_movie(args) -> int:
    kind = movie_kind(str(args.out))
    args.size = args.size or (800, 600)
    if not math.isfinite(args.fps) or not 0 < args.fps <= 240:
        raise ValueError(f"--fps {args.fps:g}: give 0 < F <= 240")
    several_times = isinstance(args.time, TimeRange)
    if several_times and (args.turntable or args.sweep):
        raise ValueError("--time all (or A:B) is the movie's motion; leave out --turntable and --sweep")
    if args.frames is not None and not args.sweep:
        raise ValueError("--frames sets a sweep's length; a turntable's is --turntable N, a series' its time points")
    if args.save_scene:
        raise ValueError("movie saves no scene; leave out --save-scene (render --save-scene does)")
    if args.labels:   # each label's surface, as render --labels draws it
        check_label_options(args, "--iso", "--panel", "--sweep")
    else:
        check_label_options(args, "--label-names")
    volume = open_volume_from_args(args.volume, args, progress, several_times=True)
    times = args.time.points(volume.time_points) if several_times else None
    from ..viewer.ui.headless import check_render_size, prepared_viewer
    from .render import drawing_context
    check_render_size(args.size)
    check_render_size(args.size, drawing_context("movie"))
    isos = None if args.labels else checked_levels(volume, args.iso, args.opacity)

    def prepare(state) -> None:
        apply_slice_arguments(state, args)
        if args.labels:
            state.show_labels(names=args.label_names)
    viewer = prepared_viewer(volume, isos, size=args.size, azimuth=args.azimuth, elevation=args.elevation,
                             transparent=False, opacities=[a for values in args.opacity or [] for a in values],
                             color_by=args.color_by, colormap=args.color_by_map, tetrahedra=args.tetrahedra,
                             smooth=args.smooth, wireframe=args.wireframe, prepare=prepare)
    try:
        frames = _frames(viewer, volume, args, times)
        path = _write(frames, args.out, kind, args.fps, _count(args, times))
    finally:
        viewer.release()
    wrote(path, f"({_count(args, times)} frames, {args.size[0]}x{args.size[1]}, {args.fps:g} fps)")
    return 0


def _count(args, times) -> int:
    if times is not None:
        return len(times)
    if args.sweep:
        return args.frames or 60
    return args.turntable or 72


def _frames(viewer, volume, args, times):
    """The movie's frames, one (H, W, 3) uint8 array at a time, each as `render` draws it."""

    def shot():
        return viewer.picture(panel=args.panel)
    if times is not None:   # the viewer's time axis: levels, slices and clip stay as time moves
        for time in times:
            if time != viewer.state.series.shown:
                viewer.state.series.go_to(time)
            yield shot()
        return
    if args.sweep:
        start, stop = args.sweep
        low, high = volume.value_range
        for value in (start, stop):
            if not low <= value <= high:
                raise ValueError(f"--sweep {start:g}:{stop:g} leaves {volume.name}'s value range {low:g} .. "
                                 f"{high:g}; sweep inside it")
        n = _count(args, times)
        for i in range(n):
            viewer.state.iso = start + (stop - start) * (i / (n - 1) if n > 1 else 0.0)
            yield shot()
        return
    azimuth = viewer.camera.azimuth
    n = _count(args, times)
    for i in range(n):
        viewer.camera.azimuth = azimuth + 360.0 * i / n
        yield shot()


def _write(frames, out, kind: str, fps: float, count: int) -> Path:
    """Write the frames beside `out` (io/movie.py), then put the whole movie in its place."""
    from ..io.movie import write_movie
    return write_movie(frames, out, fps, kind, on_frame=lambda i: count_line(i + 1, count, "frame"))
