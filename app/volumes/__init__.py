"""Volumes: what the viewer and the CLI can open, as a checked `Volume`.

Spec syntax (the VOLUME argument, the panel's picker and text box):

    sphere                 a built-in field at its default resolution (`isoscope volumes` lists them)
    sphere:128             ... at 128 samples per axis (or --resolution 128);
                           an existing file of the same name wins (write ./sphere for it anyway)
    path/to/file.npy       a file: .npy, .npz, .nrrd/.nhdr, .nii, .nii.gz, .raw (see below)
    path/to/file.npz:name  one named array of an .npz (default: the first)
    sample:bucky.raw       a small file shipped in the package's volumes/ directory
    expr:x + 2*y - 3*z + 1 an implicit function, sampled on the GPU (numpy without one);
        options after semicolons:  expr:sin(x)*cos(y); box=-3.2,3.2; res=96
        box=LO,HI (a cube) or box=X0,X1,Y0,Y1,Z0,Z1 (default -1,1), res=N (default 64).
        Grammar: numbers, x y z pi, + - * / ^ (right-assoc), parentheses,
        sin cos tan exp log sqrt abs min max. The object is where the value is
        below the level (default 0), as for F(x,y,z) < 0 inside.

Files:
    .npy / .npz    never unpickled; 4-D arrays are time points along axis 0 (--time N).
    .nrrd / .nhdr  pynrrd; spacing from "spacings" or "space directions";
                   4-D: the non-spatial axis (by "kinds"), else the last one.
    .nii / .nii.gz nibabel; spacing from the header's zooms; 4-D: axis 3 is time.
    .raw / other   --dims X Y Z (x fastest, as ParaView and the CUDA sample),
                   --dtype (default uint8), --endian little|big, --spacing X Y Z,
                   or a JSON sidecar (file.json or file.raw.json) with keys
                   dims, dtype, endian, spacing; flags win over the sidecar.
    .tif / .tiff   a stack (tifffile), z y x; spacing from ImageJ or OME metadata;
                   a time axis gives the time points (--time N).
    a folder       a DICOM series (pydicom): slices sorted along their normal,
                   rescaled (CT in HU), spacing from the slice positions and
                   PixelSpacing; axes (slice, row, column); --series N|UID picks
                   one of several series.

Which side is the object: built-ins and expr: declare it; files are taken as
densities (object above the level, as CT). `--inside below` (open_volume's
`inside="below"`) says the object is where values are below the level, as in a
signed distance field, so normals point out of it; `--inside above` the reverse.

Axis 0 of `Volume.data` is x. Integer data keeps its type and range. Every bad
input raises `VolumeError` with one line naming the problem and the fix.
"""
from __future__ import annotations

from pathlib import Path

from .builtins import BUILTINS, open_builtin, split_builtin_spec
from .errors import VolumeError
from .volume import Progress, Volume, extraction_limit

__all__ = [
    "Volume", "VolumeError", "DEFAULT_VOLUME", "open_volume", "builtin_names",
    "describe_builtins", "sample_names",
]

# Smooth, blended blobs: a closed surface with varied curvature that looks good lit
# and extracts in well under a second at 80^3 on llvmpipe.
DEFAULT_VOLUME = "metaballs"


def builtin_names() -> list[str]:
    """The built-in volumes' names, in the listing's order."""
    return list(BUILTINS)


def describe_builtins() -> list[tuple[str, str]]:
    """(name, one-line summary) of each built-in volume, for ``isoscope volumes``."""
    return [(builtin.name, builtin.summary) for builtin in BUILTINS.values()]


def sample_names() -> list[str]:
    """Specs of the small files shipped in volumes/ ("sample:bucky.raw", ...), for pickers."""
    from isoscope.resources import volumes_dir

    from .loaders import SAMPLE_PREFIX, is_volume_file
    return sorted(SAMPLE_PREFIX + path.name for path in volumes_dir().iterdir() if is_volume_file(path))


INSIDE_SIDES = {"above": "descent", "below": "ascent"}  # --inside -> Volume.gradient_direction


def open_volume(spec: str, *, dims=None, dtype=None, endian=None, spacing=None, time=None,
                series=None, resolution=None, progress: Progress | None = None, backend: str = "auto",
                ctx=None, inside: str | None = None, fits=None,
                fits_refusal: str = "more than one extraction takes; crop or downsample it",
                map_files: bool = False) -> Volume:
    """Open a volume from a spec (see the module docstring); raise VolumeError on bad input.

    dims/dtype/endian: raw files only; spacing overrides a header; time picks a time point of a
    4-D file (Volume.time_points says how many); series picks a DICOM folder's series; resolution:
    built-ins and expr: only. progress, if
    given, is called as progress(fraction 0..1, message) while a big volume
    loads, is generated or is checked. backend ("auto", "gpu", "cpu") and ctx (a
    moderngl context) only matter for expr: specs; "auto" samples on the GPU
    when a GL 4.3 context can be had and says so in `notes` when it falls back.
    inside ("above" or "below"), if given, overrides which side of the level
    the object is on. fits, if given, is a test on a 3-D shape (core.layout.fits_one_extraction):
    a file whose header gives a shape it rejects is refused before its data is read, in words
    ending with fits_refusal. map_files: a raw file, or a C-ordered 3-D .npy, is memory-mapped whatever its
    size (its data is then read by name, as dask workers do, or a block at a time by the viewer's bricks),
    not read whole when small.
    """
    if inside is not None and inside not in INSIDE_SIDES:
        raise VolumeError(f"inside must be 'above' or 'below' the level, not {inside!r}")
    with extraction_limit(fits, fits_refusal):
        volume = _open(spec, dims=dims, dtype=dtype, endian=endian, spacing=spacing, time=time, series=series,
                       resolution=resolution, progress=progress, backend=backend, ctx=ctx, map_files=map_files)
    if inside is not None:
        volume.gradient_direction = INSIDE_SIDES[inside]  # in place: keeps the checked value range
    given = dict(dims=dims, dtype=dtype, endian=endian, spacing=spacing, time=time, series=series,
                 resolution=resolution)
    volume.open_options = {name: value for name, value in given.items() if value is not None}
    return volume


def _open(spec: str, *, dims, dtype, endian, spacing, time, series, resolution, progress, backend,
          ctx, map_files) -> Volume:
    if not isinstance(spec, str) or not spec.strip():
        raise VolumeError("no volume given; name a file, a built-in (isoscope volumes) or expr:FORMULA")
    spec = spec.strip()
    file_only = dict(dims=dims, dtype=dtype, endian=endian, time=time, series=series)
    if spec.lower().startswith("expr:"):
        _refuse_options(spec, "an expression", **file_only, spacing=spacing)
        from .expression_volume import open_expression
        return open_expression(spec, resolution=resolution, progress=progress, backend=backend, ctx=ctx)
    if split_builtin_spec(spec) is not None and not Path(spec).exists():
        _refuse_options(spec, "a built-in volume", **file_only, spacing=spacing)
        return open_builtin(spec, resolution=resolution, progress=progress)
    if resolution is not None:
        raise VolumeError(f"--resolution applies to built-ins and expr: volumes, not to the file "
                          f"{spec}; drop it")
    from .loaders import open_file
    from .time_points import is_pattern, series_files, time_index, time_note
    if is_pattern(spec):   # 'run/field_*.npy': each file a time point, in natural order
        files = series_files(spec)
        index = time_index(time, len(files), spec)
        volume = open_file(str(files[index]), progress=progress, spacing=spacing, map_files=map_files,
                           **dict(file_only, time=None))
        if volume.time_points > 1:
            raise VolumeError(f"{files[index].name} is itself a series of {volume.time_points} time points; a "
                              "pattern names 3-D files, one per time point")
        volume.time_points, volume.source = len(files), spec
        volume.notes.append(time_note(index, len(files), f"series of {len(files)} files: showing time point "
                                                         f"{index}, {files[index].name} (use --time N)"))
        return volume
    return open_file(spec, progress=progress, spacing=spacing, map_files=map_files, **file_only)


def _refuse_options(spec: str, kind: str, **options) -> None:
    given = [name for name, value in options.items() if value is not None]
    if given:
        flags = " ".join(f"--{name}" for name in given)
        verb = "applies" if len(given) == 1 else "apply"
        raise VolumeError(f"{spec} is {kind}; {flags} only {verb} to files: drop {flags}")
