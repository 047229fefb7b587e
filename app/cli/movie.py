"""`isoscope movie`: a turntable, an iso sweep or a series' time points, rendered offscreen as `render`
draws them, written as an H.264 MP4 (imageio through imageio-ffmpeg's ffmpeg), a GIF (Pillow) or a
folder of numbered PNGs.  The file appears whole or not at all (written beside, then renamed)."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..core.numbers import FPS, FRAMES
from ..errors import InputError
from ..io.movie import movie_kind
from ..viewer.model.raycast import check_transfer_mode
from .arguments import OneLineParser, add_render_options
from .common import LABEL_MESH_FLAGS, check_label_options, checked_levels, count_line, progress, wrote
from .slice_options import apply_slice_arguments
from .volume_options import TimeRange, add_volume_arguments, open_volume_from_args

MAX_FRAMES = FRAMES.high


def movie_parser() -> argparse.ArgumentParser:
    """The parser of ``isoscope movie``."""
    parser = OneLineParser(prog="isoscope movie",
                          description="Render a movie offscreen: a turntable around the vertical axis, an iso sweep "
                                      "or a series' time points, to .mp4 (H.264), .gif or a folder of PNGs.")
    add_render_options(parser, out_help="the movie: NAME.mp4, NAME.gif, or a folder (ending in /) for "
                                        "frame_0000.png, ...", out_metavar="MOVIE")
    motion = parser.add_mutually_exclusive_group()
    motion.add_argument("--turntable", type=FRAMES.argument("--turntable"), metavar="N",
                        help="N frames once around the vertical axis, from --azimuth (the default motion: 72)")
    motion.add_argument("--sweep", type=_sweep, metavar="A:B",
                        help="the iso value from A to B over --frames frames (a negative A: --sweep=-0.5:0.5)")
    parser.add_argument("--frames", type=FRAMES.argument(), metavar="N", help="frames of a sweep (default 60)")
    parser.add_argument("--fps", type=FPS.argument(), default=24.0, metavar="F", help="frames per second (default 24)")
    add_volume_arguments(parser)
    return parser


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
    """``isoscope movie``: render a turntable, an iso sweep or a series' time points to a movie file or a folder of
    PNGs, after refusing flags that do not go with the motion; the exit status."""
    kind = movie_kind(str(args.out))
    args.size = args.size or (800, 600)
    several_times = isinstance(args.time, TimeRange)
    if several_times and (args.turntable or args.sweep):
        raise InputError("--time all (or A:B) is the movie's motion; leave out --turntable and --sweep")
    if args.frames is not None and not args.sweep:
        raise InputError("--frames sets a sweep's length; a turntable's is --turntable N, a series' its time points")
    if args.save_scene:
        raise InputError("movie saves no scene; leave out --save-scene (render --save-scene does)")
    if args.labels:   # each label's surface, as render --labels draws it
        check_label_options(args, "--iso", "--panel", "--sweep", *LABEL_MESH_FLAGS)
    else:
        check_label_options(args, "--label-names", "--force-labels")
    check_transfer_mode(args.raycast, args.transfer, flags=True)
    volume = open_volume_from_args(args.volume, args, progress, several_times=True)
    times = args.time.points(volume.time_points) if several_times else None
    if times is not None and len(times) > MAX_FRAMES:
        raise InputError(f"--time gives {len(times):,} time points, more frames than a movie makes ({MAX_FRAMES:,}); "
                         "choose a range, e.g. --time 0:99")
    from ..viewer.ui.headless import check_render_size, prepared_viewer
    from .render import drawing_context
    check_render_size(args.size)
    check_render_size(args.size, drawing_context("movie"))
    isos = None if args.labels else checked_levels(volume, args.iso, args.opacity)

    def prepare(state) -> None:
        """Put the slices, clip and labels asked for on the viewer's state before the first frame."""
        apply_slice_arguments(state, args)
        if args.labels:
            state.show_labels(names=args.label_names, force=args.force_labels)
    viewer = prepared_viewer(volume, isos, size=args.size, azimuth=args.azimuth, elevation=args.elevation,
                             transparent=False, opacities=[a for values in args.opacity or [] for a in values],
                             color_by=args.color_by, colormap=args.color_by_map, tetrahedra=args.tetrahedra,
                             smooth=args.smooth, wireframe=args.wireframe, prepare=prepare,
                             topology=args.topology or "montani")
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
        """One frame, as `render` draws it (with the panel and letters if asked)."""
        return viewer.picture(panel=args.panel, letters=args.orientation_letters)
    if times is not None:   # the viewer's time axis: levels, slices and clip stay as time moves
        for time in times:
            if time != viewer.state.series.shown:
                viewer.state.series.go_to(time)
            frame = shot()
            if viewer.state.series.shown != time:   # its read failed: the frame shows the time point before
                raise InputError(f"time point {time} of {volume.name} cannot be drawn "
                                 f"({viewer.state.error or 'it could not be read'}); the movie stops there")
            yield frame
        return
    if args.sweep:
        start, stop = args.sweep
        low, high = volume.value_range
        for value in (start, stop):
            if not low <= value <= high:
                raise InputError(f"--sweep {start:g}:{stop:g} leaves {volume.name}'s value range {low:g} .. "
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
