"""From a file spec to a checked Volume: find the file, pick the format's loader, apply the flags.

The format modules (npy_format, nrrd_format, nifti_format, raw_format) each
read one format and return (array, header spacing, notes); this module owns
what is common: paths and `sample:` names, --time for numpy stacks, --dims
and --spacing against the header, and the final checks in finish_volume.
"""
from __future__ import annotations

from pathlib import Path

from ..core.units import mm_per_unit
from .dicom_format import load_dicom_folder
from .errors import VolumeError
from .nifti_format import load_nifti, nifti_unit, nifti_world
from .npy_format import load_npy, load_npz
from .nrrd_format import load_nrrd, nrrd_unit, nrrd_world
from .raw_format import load_raw, sidecar_path, three_positive
from .reading import refuse_unless_regular
from .tiff_format import TIFF_SUFFIXES, load_tiff
from .time_points import select_time, time_points_of
from .volume import Progress, Volume, finish_volume, shape_text
from .zarr_format import is_zarr, load_zarr

SAMPLE_PREFIX = "sample:"
RAW_SUFFIXES = (".raw", ".bin", ".dat")
KNOWN_FORMATS = (".npy, .npz, .nrrd, .nhdr, .nii, .nii.gz, .tif/.tiff stacks, .raw (with --dims), a DICOM folder, "
                 "a Zarr or OME-Zarr folder")


def resolve_path(spec: str) -> tuple[Path, str | None]:
    """(path, npz array name). 'sample:NAME' looks in the package's volumes/ directory."""
    if spec.lower().startswith(SAMPLE_PREFIX):
        from isoscope.resources import volumes_dir
        spec = str(volumes_dir() / spec[len(SAMPLE_PREFIX):])
    path = Path(spec).expanduser()
    if not path.exists():
        # "file.npz:density" names one array of an archive.
        head, sep, array_name = spec.rpartition(":")
        if sep and head.lower().endswith(".npz") and Path(head).expanduser().is_file():
            return Path(head).expanduser(), array_name
        from difflib import get_close_matches

        from .builtins import BUILTINS
        close = get_close_matches(spec.lower(), list(BUILTINS), n=1)
        hint = f"did you mean {close[0]}? " if close else ""
        raise VolumeError(f"no such file or built-in volume: {spec} ({hint}check the path; "
                          f"`isoscope volumes` lists the built-ins)")
    return path, None


VOLUME_SUFFIXES = (".nii.gz", ".nii", ".nrrd", ".nhdr", ".npy", ".npz") + TIFF_SUFFIXES + RAW_SUFFIXES


def is_volume_file(path: Path) -> bool:
    """A file whose name says it holds a volume (sidecars, scripts and notes do not)."""
    return path.is_file() and path.name.lower().endswith(VOLUME_SUFFIXES)


def _format_of(path: Path, has_raw_flags: bool) -> str:
    if is_zarr(path):
        return "zarr"
    if path.is_dir():
        return "dicom"
    name = path.name.lower()
    for suffix, kind in ((".nii.gz", "nifti"), (".nii", "nifti"), (".nrrd", "nrrd"), (".nhdr", "nrrd"),
                         (".npy", "npy"), (".npz", "npz"), (".tiff", "tiff"), (".tif", "tiff")):
        if name.endswith(suffix):
            return kind
    if name.endswith(RAW_SUFFIXES) or has_raw_flags:
        return "raw"
    if sidecar_path(path) is not None:
        return "raw"
    raise VolumeError(f"unknown volume format: {path.name}; isoscope reads {KNOWN_FORMATS} "
                      f"(for headerless data pass --dims X Y Z --dtype T)")


def open_file(spec: str, *, dims=None, dtype=None, endian=None, spacing=None, time=None,
              series=None, progress: Progress | None = None, map_files: bool = False) -> Volume:
    """The volume in the file or folder `spec` (by its format: NIfTI, NRRD, DICOM, Zarr, numpy, raw, ...), with flags
    that do not apply to its format refused in one line."""
    path, array_name = resolve_path(spec)
    if not path.is_dir():
        refuse_unless_regular(path)  # a named pipe would block the read for good
    kind = _format_of(path, dims is not None)
    if series is not None and kind != "dicom":
        raise VolumeError(f"--series picks a series of a DICOM folder, and {path.name} is not one; drop it")
    if kind != "raw":
        for flag, value in (("--dtype", dtype), ("--endian", endian)):
            if value is not None:
                raise VolumeError(f"{path.name} has a header that gives its type; drop {flag}")
    if spacing is not None:
        spacing = three_positive(spacing, "--spacing", float, path.name)
    pyramid = ()   # lower-resolution levels that come with the volume (OME-Zarr)
    try:
        world = None  # (4x4 array index -> world mm, its space), for files that define one
        unit = None   # the length unit the file states (core.units), None where it states none: mm
        if kind == "dicom":
            data, header_spacing, notes, world = load_dicom_folder(path, None if series is None else str(series),
                                                                   progress, time)
        elif kind == "raw":
            data, header_spacing, notes = load_raw(path, dims, dtype, endian, spacing, progress, map_file=map_files)
        elif kind == "zarr":
            data, header_spacing, notes, pyramid, world, unit = load_zarr(path, time, progress)
        elif kind == "npy":
            data, header_spacing, notes = load_npy(path, progress, map_file=map_files)
        elif kind == "tiff":
            data, header_spacing, notes, unit = load_tiff(path, time, progress)
        elif kind == "npz":
            data, header_spacing, notes = load_npz(path, array_name, progress)
        elif kind == "nrrd":
            data, header_spacing, notes = load_nrrd(path, time, progress)
            world = nrrd_world(path)
            unit = nrrd_unit(path, notes)
        else:
            data, header_spacing, notes = load_nifti(path, time, progress)
            world = nifti_world(path)
            unit = nifti_unit(path)
    except MemoryError:
        raise VolumeError(f"{path.name} does not fit in memory; crop or downsample it first") from None
    except PermissionError:
        raise VolumeError(f"{path.name} cannot be read (permission denied); check its permissions") from None
    if kind in ("npy", "npz"):
        data, time_notes = select_time(data, 0, time, path.name)  # stacks of volumes: frames first
        notes += time_notes
    if kind != "raw" and dims is not None and tuple(int(d) for d in dims) != tuple(data.shape):
        raise VolumeError(f"--dims {' '.join(map(str, dims))} does not match {path.name}, whose header "
                          f"says {shape_text(data.shape)}; drop --dims (it is only for raw files)")
    if spacing is not None and header_spacing is not None and tuple(header_spacing) != spacing:
        notes.append(f"--spacing overrides the header's {tuple(round(s, 6) for s in header_spacing)}")
    if spacing is not None and world is not None:
        notes.append("--spacing given: the file's world coordinates are dropped (index x spacing)")
        world = None
    if spacing is not None and unit is not None:   # --spacing is in millimetres, as everywhere else
        if mm_per_unit(unit) != 1.0:
            notes.append(f"--spacing given: taken as millimetres, not the file's {unit}")
        unit = None
    chosen = spacing or header_spacing or (1.0, 1.0, 1.0)
    volume = finish_volume(data, spacing=chosen, name=path.name if array_name is None else f"{path.name}:{array_name}",
                         source=spec, gradient_direction="descent", default_level=None,
                         notes=notes, what=path.name, progress=progress, world=world,
                         length_unit=unit)
    volume.time_points = time_points_of(notes)
    if pyramid:   # each level's spacing in the spacing chosen (--spacing scales them alike)
        ratio = [c / h for c, h in zip(chosen, header_spacing or (1.0, 1.0, 1.0))]
        volume.pyramid = tuple(level._replace(spacing=tuple(s * r for s, r in zip(level.spacing, ratio)))
                               for level in pyramid)
    return volume
