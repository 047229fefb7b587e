"""Label names and colours for a segmentation, from the two text formats the segmentation tools write.

ITK-SNAP's label description file (`label_description.txt`, Segmentation > Export Label Descriptions):

    # IDX   -R-  -G-  -B-  -A--  VIS MSH  LABEL
        1   255    0    0     1    1   1  "Left hippocampus"

R G B are 0..255, A the label's opacity 0..1, VIS/MSH whether the label and its mesh are shown;
the name is quoted and may hold spaces.  3D Slicer's colour table (`.ctbl`, and FreeSurfer's
`FreeSurferColorLUT.txt`, the same layout):

    # index name R G B A
    1 tissue 128 174 128 255

one name without spaces, R G B A 0..255.  The alpha there is not taken as opacity: FreeSurfer's
tables write 0 for every label, and Slicer draws segments opaque whatever it says.

Plain Python: both are a line per label with '#' comments, and no maintained library reads them.
A line that does not parse raises `VolumeError` naming the file, the line and the layout expected.
"""
from __future__ import annotations

import shlex
from dataclasses import dataclass
from pathlib import Path

from ..core.opener import read_text, shown
from ..errors import InputError
from .errors import VolumeError

ITKSNAP_LAYOUT = 'IDX R G B A VIS MSH "LABEL" (ITK-SNAP label description)'
SLICER_LAYOUT = "index name R G B A (3D Slicer colour table)"
# FreeSurfer's LUT, the largest table in use, is ~100 kB and 1,300 labels; a label is a 16-bit value or so
MAX_TABLE_BYTES = 16 << 20
MAX_TABLE_LABELS = 65_536
SIDE_SUFFIXES = (".ctbl", ".txt", "_label_description.txt")
"""`beside(path)` looks for STEM + each of these next to the segmentation, in this order."""
VOLUME_SUFFIXES = (".nii.gz", ".nii", ".nrrd", ".nhdr", ".mha", ".mhd", ".npy", ".npz", ".tif",
                   ".tiff", ".zarr", ".raw")


@dataclass(frozen=True)
class LabelName:
    """A label's look from a label file: its name, RGB colour 0..1, opacity and whether it is shown."""
    name: str
    color: tuple[float, float, float]   # RGB 0..1
    opacity: float = 1.0
    visible: bool = True


def read_label_names(path) -> dict[int, LabelName]:
    """{label: LabelName} from an ITK-SNAP label description file or a Slicer colour table at `path`
    (which one: by the first label's line: a quoted name is ITK-SNAP's).  Label 0 (the background)
    is kept if listed; the viewer draws no surface for it."""
    path = Path(path)
    text = read_text(path, "the label names file", MAX_TABLE_BYTES, errors="replace")
    name = shown(path.name)
    names: dict[int, LabelName] = {}
    layout = None
    for number, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if layout is None:
            layout = ITKSNAP_LAYOUT if '"' in line else SLICER_LAYOUT
        try:
            label, entry = _itksnap_line(line) if layout is ITKSNAP_LAYOUT else _slicer_line(line)
        except ValueError as exc:
            raise VolumeError(f"{name} line {number}: {exc}; each line must be {layout}: "
                              f"fix that line or pass another file with --label-names") from None
        if label in names:
            raise VolumeError(f"{name} line {number}: label {label} is listed twice; keep one of its lines")
        if len(names) >= MAX_TABLE_LABELS:
            raise VolumeError(f"{name} lists more than {MAX_TABLE_LABELS:,} labels; is it a label table?")
        names[label] = entry
    if not names:
        raise VolumeError(f"{name} lists no labels; each line must be {ITKSNAP_LAYOUT} or {SLICER_LAYOUT}")
    return names


def _itksnap_line(line: str) -> tuple[int, LabelName]:
    try:
        fields = shlex.split(line)
    except ValueError:
        raise InputError("its quoted name is not closed") from None
    if len(fields) != 8:
        raise InputError(f"{len(fields)} fields, not 8")
    label, red, green, blue = (_whole(text, what) for text, what in zip(fields[:4], ("IDX", "R", "G", "B")))
    opacity = _number(fields[4], "A", 1.0)
    visible, mesh = (_whole(text, what) for text, what in zip(fields[5:7], ("VIS", "MSH")))
    if visible not in (0, 1) or mesh not in (0, 1):
        raise InputError(f"VIS and MSH must be 0 or 1, not {fields[5]} {fields[6]}")
    return label, LabelName(shown(fields[7]), _color(red, green, blue), opacity, bool(visible and mesh))


def _slicer_line(line: str) -> tuple[int, LabelName]:
    fields = line.split()
    if len(fields) != 6:
        raise InputError(f"{len(fields)} fields, not 6 (a name with spaces needs the ITK-SNAP layout)")
    label = _whole(fields[0], "index")
    red, green, blue, alpha = (_whole(text, what) for text, what in zip(fields[2:], "RGBA"))
    if not 0 <= alpha <= 255:
        raise InputError(f"A is {alpha}, not 0..255")
    return label, LabelName(shown(fields[1]), _color(red, green, blue))


def _whole(text: str, what: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise InputError(f"{what} is {text!r}, not a whole number") from None


def _number(text: str, what: str, high: float) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{what} is {text!r}, not a number") from None
    if not 0 <= value <= high:
        raise InputError(f"{what} is {text}, not 0..{high:g}")
    return value


def _color(red: int, green: int, blue: int) -> tuple[float, float, float]:
    for value, what in ((red, "R"), (green, "G"), (blue, "B")):
        if not 0 <= value <= 255:
            raise InputError(f"{what} is {value}, not 0..255")
    return (red / 255, green / 255, blue / 255)


def beside(source) -> Path | None:
    """The label names file next to the segmentation file `source`: its stem (the name less its volume
    suffix, seg.nii.gz -> seg) + .ctbl, .txt or _label_description.txt, the first that exists; else None."""
    path = Path(str(source))
    if not path.is_file():
        return None
    name = path.name
    stem = next((name[:-len(suffix)] for suffix in VOLUME_SUFFIXES if name.lower().endswith(suffix)), path.stem)
    for suffix in SIDE_SUFFIXES:
        candidate = path.with_name(stem + suffix)
        if candidate.is_file():
            return candidate
    return None


def label_names_for(source, given=None) -> dict[int, LabelName]:
    """The names for the segmentation `source`: from `given` (a path: --label-names), else from the file
    beside it (`beside`), else none ({})."""
    path = given if given is not None else beside(source)
    return read_label_names(path) if path is not None else {}
