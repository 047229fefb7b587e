"""The command-line flags that describe a volume, shared by every isoscope subcommand."""
from __future__ import annotations

import argparse
from dataclasses import dataclass

from ..volumes.errors import VolumeError
from ..volumes.raw_format import RAW_DTYPES
from ..volumes.volume import Progress, Volume


@dataclass(frozen=True)
class TimeRange:
    """--time all or A:B: the time points start .. stop - 1 (stop None: to the end)."""
    start: int
    stop: int | None
    text: str

    def points(self, count: int) -> range:
        """The time points of a series of `count`, refused in one line where the range leaves it."""
        stop = count if self.stop is None else self.stop
        if self.start >= count or stop > count:
            raise VolumeError(f"--time {self.text} is past the end: the series has {count} time points "
                              f"(0..{count - 1})")
        return range(self.start, stop)


def time_spec(text: str) -> int | TimeRange:
    """'3' -> 3; 'all' -> every time point; '2:5' -> 2, 3, 4 (either end may be left out)."""
    text = text.strip()
    if text.lower() == "all":
        return TimeRange(0, None, "all")
    start, colon, stop = text.partition(":")
    try:
        first = int(start) if start.strip() else 0
        last = int(stop) if stop.strip() else None
    except ValueError:
        raise argparse.ArgumentTypeError(f"--time {text!r} is not a time point N, 'all' or a range A:B") from None
    if first < 0 or (last is not None and last <= first):
        raise argparse.ArgumentTypeError(f"--time {text!r}: time points count from 0, and a range A:B needs A < B")
    return TimeRange(first, last, text) if colon else first


def add_volume_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the flags that say how to read VOLUME to `parser`: raw files' layout, spacing, time point, DICOM series,
    built-ins' resolution."""
    group = parser.add_argument_group("volume options")
    group.add_argument("--dims", nargs=3, type=int, metavar=("X", "Y", "Z"),
                       help="raw files: samples along x, y, z (x varies fastest)")
    group.add_argument("--dtype", choices=RAW_DTYPES, help="raw files: sample type (default uint8)")
    group.add_argument("--endian", choices=("little", "big"), help="raw files: byte order (default little)")
    group.add_argument("--spacing", nargs=3, type=float, metavar=("X", "Y", "Z"),
                       help="voxel size along x, y, z (overrides the header)")
    group.add_argument("--time", "--frame", dest="time", type=time_spec, metavar="N|all|A:B",
                       help="4-D files (series): the time point to show (default 0); export also takes 'all' "
                            "or A:B (points A to B-1) and writes one mesh per point, NAME_t000.EXT, ...")
    group.add_argument("--series", metavar="N|UID",
                       help="DICOM folders holding several series: which one (its number in the listing, or its UID)")
    group.add_argument("--resolution", type=int, metavar="N",
                       help="built-ins and expr: samples per axis")
    group.add_argument("--inside", choices=("above", "below"),
                       help="which side of the level the object is on, so normals point out of it: "
                            "'above' for densities such as CT (files' default), 'below' for signed "
                            "distances (built-ins and expr: say their own)")


def open_volume_from_args(spec: str, args: argparse.Namespace, progress: Progress | None = None,
                          backend: str = "auto", several_times: bool = False, **more) -> Volume:
    """The volume the flags describe (with --time all or A:B, where `several_times` allows it, its first
    time point); `backend` samples expr: volumes ("auto", "gpu" or "cpu"); `more` (fits, fits_refusal,
    map_files) goes to open_volume."""
    from ..volumes import open_volume
    from ..volumes.reading import maps_within
    names = ("dims", "dtype", "endian", "spacing", "time", "series", "resolution", "inside")
    options = {name: getattr(args, name) for name in names}
    if isinstance(options["time"], TimeRange):
        if not several_times:
            raise VolumeError(f"--time {options['time'].text} picks several time points, which export, measure "
                              "and movie take (a mesh, a row, a frame each); give one here, --time N")
        options["time"] = options["time"].start
    if options["spacing"] is not None:
        _checked_spacing(options["spacing"], None, "--spacing")  # before a big file is read
    # finish_volume holds the spacing (the header's, or --spacing) to the same rule against the shape.
    if maps_within(spec, getattr(args, "memory_budget", None)):
        more.setdefault("map_files", True)   # a file over --memory-budget is not read whole into memory
    return open_volume(spec, progress=progress, backend=backend, **options, **more)


def each_time_point(spec: str, args: argparse.Namespace, progress: Progress | None = None, **more):
    """(time point, volume) for each time point --time names: (None, the volume) for one (or none given),
    else each of --time all or A:B in turn, read one at a time, each the first one's shape."""
    from ..volumes.time_points import same_shape
    volume = open_volume_from_args(spec, args, progress, several_times=True, **more)
    if not isinstance(args.time, TimeRange):
        yield None, volume
        return
    points = args.time.points(volume.time_points)
    first_shape = volume.data.shape
    for time in points:
        if time != points[0]:
            volume = open_volume_from_args(spec, argparse.Namespace(**{**vars(args), "time": time}), progress, **more)
            same_shape(volume, first_shape, time)
        yield time, volume


def _checked_spacing(spacing, shape, what: str) -> None:
    """validation.as_spacing, the rule the Python API applies too, as a one-line VolumeError."""
    from ..validation import as_spacing
    try:
        as_spacing(spacing, shape)
    except ValueError as exc:
        raise VolumeError(f"{what}: {exc}") from None
