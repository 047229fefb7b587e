"""What the command's runners share: its exit codes, progress and 'wrote' lines, and the checks of --iso."""
from __future__ import annotations

import os
import sys

from ..errors import InputError
from ..volumes import VolumeError

EXIT_BAD_INPUT = 2
EXIT_NO_GL = 1
EXIT_CLUSTER_FAILED = 1  # the machine, not the input: a cluster failed, the disk is full
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE: the reader of stdout went away (`| head`)



def progress(fraction: float, message: str) -> None:
    """Report a slow step: one line overwritten on a terminal, one line per report where ISOSCOPE_PROGRESS is set (the
    viewer's background export reads them), nothing otherwise."""
    # Slow loads report progress; overwrite one line on a terminal, stay quiet in logs.  With
    # ISOSCOPE_PROGRESS set (the viewer's background export reads them), one line per report.
    if sys.stderr.isatty():
        end = "\n" if fraction >= 1.0 else ""
        print(f"\r{message} {fraction:4.0%}\033[K", end=end, file=sys.stderr, flush=True)
    elif os.environ.get("ISOSCOPE_PROGRESS"):
        print(f"{message} {fraction:.0%}", file=sys.stderr, flush=True)


def checked_iso(volume, iso: float | None) -> float | None:
    """The --iso value, or the volume's default level when none was given; a VolumeError when it lies outside the
    volume's value range."""
    if iso is None:
        return volume.default_level
    low, high = volume.value_range
    if not low <= iso <= high:
        raise VolumeError(f"--iso {iso:g} is outside {volume.name}'s value range {low:g} .. {high:g}; "
                          "pick a value inside it")
    return iso


def checked_levels(volume, isos: list[float] | None, opacity_lists=None) -> list[float | None]:
    """The --iso values (one None: the default level), each in range, at most MAX_LEVELS; and
    no more --opacity values than levels."""
    from ..viewer.model.levels import MAX_LEVELS
    isos = isos or [None]
    if len(isos) > MAX_LEVELS:
        raise VolumeError(f"--iso given {len(isos)} times; at most {MAX_LEVELS} surfaces at once")
    given = sum(len(values) for values in opacity_lists or [])
    if given > len(isos):
        raise VolumeError(f"{given} opacities for {len(isos)} levels; give one per --iso, in order")
    return [checked_iso(volume, iso) for iso in isos]


def level_path(out, level: float) -> str:
    """Where export writes `level` when given several: STEM_iso<V>.EXT beside `out`."""
    from pathlib import Path
    out = Path(out)
    return str(out.with_name(f"{out.stem}_iso{level:g}{out.suffix}"))


LABEL_MESH_FLAGS = ("--tetrahedra", "--smooth", "--sharp", "--topology")
"""Mesh modes a label map's surfaces do not take: each is marching cubes of the label's 0/1 indicator at 0.5 with
the label table (labels.py), whose every vertex is an edge's midpoint; the trilinear topology has nothing to decide
there (every ambiguous face's saddle sits exactly at the level)."""


def check_label_options(args, *options: str) -> None:
    """--labels draws or writes every label's boundary: refuse the options that have no meaning there."""
    for option in options:
        if getattr(args, option.strip("-").replace("-", "_"), None) not in (None, False):
            raise InputError(f"{option} does not apply with --labels (each label's surface is its boundary); "
                             f"leave out {option}" if args.labels else f"{option} needs --labels; add --labels")


def wrote(path, what: str) -> None:
    """Say what was written, on stdout; on stderr where the file written is stdout itself (`--out
    /dev/stdout | viewer`), so the line does not land in the PNG or mesh."""
    try:
        into_stdout = os.path.samefile(path, "/dev/stdout")
    except (OSError, ValueError):
        into_stdout = False
    print(f"wrote {path}{'' if what.startswith(':') else ' '}{what}", file=sys.stderr if into_stdout else sys.stdout)


def count_line(done: int, count: int, what: str) -> None:
    """`what done/count`, one line rewritten on a terminal only (captured output keeps its one-line errors):
    the progress of a movie's frames or an export's time points."""
    if sys.stderr.isatty():
        end = "\n" if done == count else ""
        print(f"\r{what} {done}/{count}\033[K", end=end, file=sys.stderr, flush=True)
