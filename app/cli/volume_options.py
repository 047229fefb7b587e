"""The command-line flags that describe a volume, shared by every isoscope subcommand."""
from __future__ import annotations

import argparse

from ..volumes.errors import VolumeError
from ..volumes.raw_format import RAW_DTYPES
from ..volumes.volume import Progress, Volume


def add_volume_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("volume options")
    group.add_argument("--dims", nargs=3, type=int, metavar=("X", "Y", "Z"),
                       help="raw files: samples along x, y, z (x varies fastest)")
    group.add_argument("--dtype", choices=RAW_DTYPES, help="raw files: sample type (default uint8)")
    group.add_argument("--endian", choices=("little", "big"), help="raw files: byte order (default little)")
    group.add_argument("--spacing", nargs=3, type=float, metavar=("X", "Y", "Z"),
                       help="voxel size along x, y, z (overrides the header)")
    group.add_argument("--frame", type=int, metavar="N", help="4-D files: which volume to show (default 0)")
    group.add_argument("--series", metavar="N|UID",
                       help="DICOM folders holding several series: which one (its number in the listing, or its UID)")
    group.add_argument("--resolution", type=int, metavar="N",
                       help="built-ins and expr: samples per axis")
    group.add_argument("--inside", choices=("above", "below"),
                       help="which side of the level the object is on, so normals point out of it: "
                            "'above' for densities such as CT (files' default), 'below' for signed "
                            "distances (built-ins and expr: say their own)")


def open_volume_from_args(spec: str, args: argparse.Namespace, progress: Progress | None = None,
                          backend: str = "auto", **more) -> Volume:
    """The volume the flags describe; `backend` samples expr: volumes ("auto", "gpu" or "cpu");
    `more` (fits, fits_refusal, map_files) goes to open_volume."""
    from ..volumes import open_volume
    names = ("dims", "dtype", "endian", "spacing", "frame", "series", "resolution", "inside")
    options = {name: getattr(args, name) for name in names}
    if options["spacing"] is not None:
        _checked_spacing(options["spacing"], None, "--spacing")  # before a big file is read
    # finish_volume holds the spacing (the header's, or --spacing) to the same rule against the shape.
    return open_volume(spec, progress=progress, backend=backend, **options, **more)


def _checked_spacing(spacing, shape, what: str) -> None:
    """validation.as_spacing, the rule the Python API applies too, as a one-line VolumeError."""
    from ..validation import as_spacing
    try:
        as_spacing(spacing, shape)
    except ValueError as exc:
        raise VolumeError(f"{what}: {exc}") from None
