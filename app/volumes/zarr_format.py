"""Zarr arrays (format v2 and v3) and OME-Zarr multiscale images, opened lazily with the `zarr` library.

Nothing is read at open but metadata: the Volume's data is a lazy view (lazy_arrays.Block3D)
that the checks and the chunked extractor read a block at a time, so the volume may be far
larger than memory.  Axes stay as stored (OME-Zarr: z, y, x), as for TIFF stacks.

A path is a Zarr array, or a group: an OME-Zarr image (its "multiscales" metadata, under
attrs["ome"] from OME-Zarr 0.5) opens its full-resolution level with the spacing of its
"scale" coordinate transformations (the dataset's times the image's), and keeps its lower-resolution
levels as the volume's pyramid (each checked against the level before it); any other group opens
its first array.  "translation" transformations are honoured, in order (the dataset's, then the image's:
the image's scale scales the dataset's translation): the full level's scale and translation are the
volume's world frame (`Volume.world`, space "OME-Zarr", axes z y x as stored; none without a translation),
and each coarser level's translation less the full level's is its offset (`PyramidLevel.offset`): where its
sample 0 sits, which for a pyramid of block means is the centre of the first block, not sample 0.
Leading non-spatial axes (time, channel): --time N picks along the first one longer than 1.
"""
from __future__ import annotations

import math
import zlib
from pathlib import Path

import numpy as np

from ..core.lazy_arrays import Block3D
from ..core.units import TAKEN_AS_MM, length_unit_name, one_length_unit
from .errors import VolumeError
from .reading import damaged, reason
from .time_points import time_index, time_note
from .volume import Progress, PyramidLevel, refuse_if_too_big, report, shape_text

MARKERS = (".zarray", ".zgroup", "zarr.json")
# What a store's metadata may claim before a byte is read: each chunk is a read with its own
# overhead (2000^3 samples in 1^3 chunks ran for minutes), and every sample is scanned once.
MAX_CHUNKS = 1 << 18  # 4096^3 in 64^3 chunks
MAX_SAMPLES = 1 << 40  # 4 TiB of float32
OME_ZARR_SPACE = "OME-Zarr"
"""The world frame's name for an OME-Zarr image's scale and translation: the file's own units along its z, y,
x axes, no patient frame (volume.ANATOMICAL_SPACES)."""


class CheckedReads:
    """A Zarr array whose failed reads (random bytes for a chunk: zstd's RuntimeError, a bad
    codec, a missing shard) are one VolumeError line about the store, wherever the read happens:
    the value scan, the chunked extractor, or a dask worker (it pickles with its array)."""

    def __init__(self, array, name: str):
        self.array, self.name = array, name
        self.shape, self.dtype, self.chunks = tuple(array.shape), array.dtype, tuple(array.chunks)

    def __getitem__(self, index):
        try:
            return self.array[index]
        except (ValueError, RuntimeError, OSError, KeyError, EOFError, zlib.error) as exc:  # what zarr and its
            # codecs raise for a damaged chunk: zstd and blosc a RuntimeError, a bad shape a ValueError
            _settle_pending_reads()
            raise VolumeError(f"{self.name}: a chunk of it cannot be read ({reason(exc)}); the store is damaged, "
                              "write it again") from None


def is_zarr(path: Path) -> bool:
    """Whether `path` is a Zarr store: a folder named .zarr, or one holding Zarr's metadata files."""
    return path.is_dir() and (path.name.lower().endswith(".zarr") or any((path / m).is_file() for m in MARKERS))


def load_zarr(path: Path, time: int | None, progress: Progress | None = None):
    """(lazy 3-D array, spacing or None, notes, pyramid, world or None, length unit or None): an OME-Zarr image's
    lower-resolution levels as PyramidLevels (finest first; none for a plain array), read as lazily as the full
    one; its world frame where its full level has a translation (the module's docstring); its axes' unit."""
    import zarr
    report(progress, 0.0, f"opening {path.name}")
    try:
        node = zarr.open(store=str(path), mode="r")
    except Exception as exc:  # zarr raises many kinds for a damaged store
        raise damaged(path, exc, "check that it is a Zarr array or an OME-Zarr image") from None
    spacing, notes, spatial, coarser, world, unit = None, [], 3, [], None, None
    if isinstance(node, zarr.Group):
        multiscales = node.attrs.get("multiscales") or dict(node.attrs.get("ome") or {}).get("multiscales")
        if multiscales:
            node, spacing, spatial, notes, coarser, world = _ome_level(node, multiscales[0], path)
            unit = _length_unit(multiscales[0], path, notes)
        else:
            arrays = sorted(node.array_keys())
            if not arrays:
                raise VolumeError(f"{path.name} is a Zarr group with no arrays; open the array's folder itself")
            notes.append(f"{path.name}: showing array {arrays[0]!r} of {len(arrays)}"
                         f" (open {path.name}/NAME for another)" if len(arrays) > 1 else "")
            node = node[arrays[0]]
    shape = tuple(node.shape)
    if len(shape) < 3 or spatial < 3:
        raise VolumeError(f"{path.name} holds a {len(shape)}-D array ({shape_text(shape)}) with "
                          f"{min(spatial, len(shape))} spatial axes; isoscope needs 3 spatial axes")
    lead = [0] * (len(shape) - 3)
    if lead:  # --time indexes the first leading axis longer than 1 (OME-Zarr's t, else c); the others take 0
        axis = next((a for a, n in enumerate(shape[:len(lead)]) if n > 1), 0)
        index = lead[axis] = time_index(time, shape[axis], path.name)
        if shape[axis] > 1:
            notes.append(time_note(index, shape[axis]))
    _refuse_unreadable_size(path, shape[-3:], tuple(node.chunks[-3:]), node.dtype)
    notes.append(f"Zarr {shape_text(shape[-3:])} {node.dtype} in {shape_text(node.chunks[-3:])} chunks, "
                 "read on demand")
    pyramid = tuple(PyramidLevel(Block3D(CheckedReads(level, f"{path.name}/{name}"), tuple(lead)), level_spacing,
                                 name, offset)
                    for name, level, level_spacing, offset in coarser
                    if tuple(level.shape[:-3]) == shape[:-3] and all(2 <= n for n in level.shape[-3:]))
    return (Block3D(CheckedReads(node, path.name), tuple(lead)), spacing, [n for n in notes if n], pyramid, world,
            unit)


def _length_unit(multiscale: dict, path: Path, notes: list[str]) -> str | None:
    """The unit the image's spatial axes state ("micrometer", ...), or None where they state none.  Spatial axes
    that state different units, or one that is no length unit known here, are taken as stating none, with a note:
    the samples still open and show; only measures (taken as millimetres then) depend on it."""
    axes = [a for a in multiscale.get("axes") or [] if isinstance(a, dict) and a.get("type") == "space"]
    stated = [a.get("unit") for a in axes[-3:]]
    if not any(u is not None for u in stated):
        return None
    unit = one_length_unit(stated)
    if unit is not None:
        return unit
    said = ", ".join(f"{a.get('name', '?')}: {u!r}" for a, u in zip(axes[-3:], stated))
    why = ("not one length unit for all three" if all(length_unit_name(u) for u in stated)
           else "not a length unit isoscope knows")
    notes.append(f"{path.name}: its spatial axes' units ({said}) are {why}; {TAKEN_AS_MM} "
                 "(write one unit such as \"micrometer\" on every spatial axis)")
    return None


def _settle_pending_reads() -> None:
    """Let zarr's event loop finish the reads that were in flight beside the one that failed: left
    pending, asyncio prints "Task was destroyed but it is pending!" for each at exit."""
    import asyncio
    try:
        from zarr.core.sync import sync
        sync(asyncio.sleep(0.01))
    except Exception:  # noqa: S110 (a zarr without this module: nothing to settle)
        pass


def _refuse_unreadable_size(path: Path, shape, chunks, dtype) -> None:
    """Refuse, from the metadata alone, a volume of more chunks or samples than can be read here,
    or whose one chunk does not fit in memory."""
    samples = math.prod(int(n) for n in shape)
    count = math.prod(-(-int(n) // max(1, int(c))) for n, c in zip(shape, chunks))
    fix = "rechunk it (e.g. 64^3 chunks) or write a smaller level"
    if samples > MAX_SAMPLES:
        raise VolumeError(f"{path.name} is {shape_text(shape)} ({samples:,} samples), more than the {MAX_SAMPLES:,} "
                          "isoscope reads; open a lower-resolution level or a crop of it")
    if count > MAX_CHUNKS:
        raise VolumeError(f"{path.name} is {shape_text(shape)} in {shape_text(chunks)} chunks: {count:,} chunks to "
                          f"read, more than {MAX_CHUNKS:,}; {fix}")
    refuse_if_too_big(chunks, dtype.itemsize, f"{path.name}'s chunk", fix=fix, whole_volume=False)


def _ome_level(group, multiscale: dict, path: Path):
    """(array of the full-resolution level, its (z, y, x) spacing or None, spatial axis count, notes, the
    lower-resolution levels as (name, array, spacing, offset), finest first, world frame or None).  A level
    whose metadata does not parse is left out of the pyramid with a note (the full one must open); a level
    named but absent from the store, or one that is not a lower resolution of the level before it (larger, or
    a scale its shape does not match), or a translation that is not one finite number per axis, is refused in
    one line: the pyramid would be shown at the wrong size or place.  A level whose translation puts its sample
    0 more than one of its samples from where its scale does is left out with a note (`_far_level`)."""
    try:
        datasets = multiscale["datasets"]
        level = group[datasets[0]["path"]]
    except (KeyError, IndexError, TypeError) as exc:
        raise VolumeError(f"{path.name}: its OME-Zarr multiscales metadata names no readable level "
                          f"({reason(exc)}); write it again") from None
    if not hasattr(level, "shape"):   # a group where its full level should be
        raise VolumeError(f"{path.name}: its OME-Zarr level {str(datasets[0]['path'])!r} is a group, not an array; "
                          "write the level again")
    axes = multiscale.get("axes") or [{"name": n, "type": "space"} for n in "zyx"[-len(level.shape):]]
    axes = [{"name": a, "type": "space" if a in "zyx" else ""} if isinstance(a, str) else a for a in axes]
    spatial = sum(1 for a in axes if a.get("type") == "space")
    first = str(datasets[0]["path"])
    notes = [f"OME-Zarr level {first!r} of {len(datasets)} (full resolution)"]
    try:
        spacing, shift = _frame_of(datasets[0], multiscale, len(level.shape), path, first)
    except VolumeError:
        raise
    except (TypeError, ValueError, AttributeError) as exc:
        raise VolumeError(f"{path.name}: the scale of its OME-Zarr level {first!r} is not a list of "
                          f"numbers ({reason(exc)}); write it again") from None
    _refuse_bad_scale(path, first, spacing)
    coarser, before = [], (first, level, spacing)
    for dataset in datasets[1:]:
        name = dataset.get("path") if isinstance(dataset, dict) else None
        if name is not None and not hasattr(group.get(str(name)), "shape"):   # named, absent: no pyramid to trust
            raise VolumeError(f"{path.name}: its OME-Zarr metadata names level {str(name)!r}, which is not an array "
                              "in the store; write the level, or drop it from the multiscales datasets")
        try:
            array = group[name]
            level_spacing, level_shift = _frame_of(dataset, multiscale, len(array.shape), path, str(name))
        except VolumeError:   # a translation that is no numbers: refused, as a scale that is not positive
            raise
        except (KeyError, IndexError, TypeError, ValueError, AttributeError) as exc:
            notes.append(f"OME-Zarr level {name if name is not None else dataset!r} left out ({reason(exc)})")
            continue
        _refuse_disagreeing_level(path, before, (str(name), array, level_spacing))
        before = (str(name), array, level_spacing)
        offset = tuple((b - a) / s for a, b, s in zip(shift or (0.0,) * 3, level_shift or (0.0,) * 3, spacing))
        far = _far_level(path, (first, spacing, shift), (str(name), level_spacing, level_shift), offset)
        if far is not None:   # the full level still opens: only this level's place is wrong
            notes.append(far)
            continue
        coarser.append((str(name), array, level_spacing, offset))
    world = None
    if shift is not None:   # the full level's scale and translation: an affine with a diagonal and an offset
        matrix = np.diag([*spacing, 1.0])
        matrix[:3, 3] = shift
        world = (matrix, OME_ZARR_SPACE)
    return level, spacing, spatial, notes, coarser, world


def _refuse_disagreeing_level(path: Path, before, level) -> None:
    """Refuse (one VolumeError line) a level `(name, array, spacing)` that is not a lower resolution of the
    one `before` it: larger along an axis, or whose scale does not match how many fewer samples it has (its
    sample spans `r` of the level before's, so its `n` samples span that level's `m` when |n r - m| <= r)."""
    (first, above, above_spacing), (name, array, spacing) = before, level
    shape, above_shape = tuple(array.shape[-3:]), tuple(above.shape[-3:])
    fix = "write the pyramid again, finest level first, each level's scale its own"
    if len(array.shape) != len(above.shape):
        raise VolumeError(f"{path.name}: OME-Zarr level {name!r} has {len(array.shape)} axes and level {first!r} "
                          f"before it {len(above.shape)}; {fix}")
    if any(n > m for n, m in zip(shape, above_shape)):
        raise VolumeError(f"{path.name}: OME-Zarr level {name!r} ({shape_text(shape)}) is larger than level "
                          f"{first!r} before it ({shape_text(above_shape)}); {fix}")
    _refuse_bad_scale(path, name, spacing)
    ratio = [s / a for s, a in zip(spacing, above_spacing)]
    if any(abs(n * r - m) > max(r, 1.0) + 1e-6 for n, m, r in zip(shape, above_shape, ratio)):
        raise VolumeError(f"{path.name}: OME-Zarr level {name!r} ({shape_text(shape)}, scale {_scale_text(spacing)}) "
                          f"does not match level {first!r} ({shape_text(above_shape)}, scale "
                          f"{_scale_text(above_spacing)}): its scale says one sample in "
                          f"{_scale_text(ratio)}, its shape one in "
                          f"{_scale_text([m / max(n, 1) for n, m in zip(shape, above_shape)])}; {fix}")


def _far_level(path: Path, full, level, offset) -> str | None:
    """The note that leaves out a coarser level `(name, spacing, translation)` whose sample 0 lies more than one
    of its own samples from where its scale puts it (the full level's sample 0): |offset| (in the full level's
    samples) above its spacing over the full level's, along an axis; drawn, it would be in the wrong place (a
    pyramid of means is half a block in, (f - 1) / 2).  None where it is in its place.  Left out, not refused:
    a writer that gives only the full level a translation (a stage position) still opens, the full level whole."""
    (first, full_spacing, full_shift), (name, spacing, shift) = full, level
    ratio = [s / f for s, f in zip(spacing, full_spacing)]
    if all(abs(o) <= r * (1 + 1e-9) for o, r in zip(offset, ratio)):
        return None
    return (f"OME-Zarr level {name!r} left out: its translation ({_scale_text(shift or (0.0,) * 3)}, scale "
            f"{_scale_text(spacing)}) puts its sample 0 {_scale_text(offset)} samples of level {first!r} from that "
            f"level's (translation {_scale_text(full_shift or (0.0,) * 3)}), more than one of its own "
            f"({_scale_text(ratio)}); {path.name} would show it in the wrong place")


def _refuse_bad_scale(path: Path, name: str, spacing) -> None:
    """Refuse (one VolumeError line) a level whose scale is not positive and finite along every axis."""
    if any(not (math.isfinite(s) and s > 0) for s in spacing):
        raise VolumeError(f"{path.name}: OME-Zarr level {name!r} has scale {_scale_text(spacing)}, not positive; "
                          "write the pyramid again, finest level first, each level's scale its own")


def _scale_text(values) -> str:
    return "x".join(f"{v:g}" for v in values)


def _frame_of(dataset: dict, multiscale: dict, ndim: int, path: Path, name: str):
    """((z, y, x) scale, (z, y, x) translation or None where none is given) of one OME-Zarr level: its dataset's
    coordinateTransformations, then the image's, each applied in its order (a scale scales the translation
    before it).  One VolumeError line refuses a scale or translation stored in a file ("path": isoscope reads
    only inline ones), a scale list or a translation that is not one number per axis, and a translation that
    its scale makes infinite (a scale that is not positive and finite is refused by the caller)."""
    scale, shift, shifted = [1.0] * ndim, [0.0] * ndim, False
    for owner, transforms in (("its", dataset.get("coordinateTransformations", [])),
                              ("the image's", multiscale.get("coordinateTransformations", []))):
        for transform in transforms:
            kind = transform.get("type")
            if kind in ("scale", "translation") and kind not in transform and "path" in transform:
                raise VolumeError(f"{path.name}: OME-Zarr level {name!r} has its {kind} in a file "
                                  f"({_short(transform['path'])}) in {owner} coordinateTransformations; isoscope "
                                  f"reads only inline transformations: write it again with the {kind}'s numbers "
                                  "in the metadata")
            if kind == "scale":
                value = transform.get("scale", [])
                if isinstance(value, (list, tuple)) and len(value) != ndim:
                    _refuse_not_per_axis(path, name, "scale", value, owner, ndim)
                factors = [float(b) for b in value]
                scale = [a * b for a, b in zip(scale, factors)]
                shift = [a * b for a, b in zip(shift, factors)]
            elif kind == "translation":
                shift = [a + b for a, b in zip(shift, _translation(transform.get("translation"), ndim, path, name,
                                                                   owner))]
                shifted = True
    finite_scale = all(math.isfinite(s) for s in scale)
    if shifted and finite_scale and not all(math.isfinite(v) for v in shift):
        raise VolumeError(f"{path.name}: OME-Zarr level {name!r} has a translation its scale makes "
                          f"{_scale_text(shift)}, not finite; write it again with numbers whose product is finite")
    return tuple(scale[-3:]), (tuple(shift[-3:]) if shifted else None)


def _short(value) -> str:
    """`value`'s repr, cut to 60 characters."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _refuse_not_per_axis(path: Path, name: str, kind: str, value, owner: str, ndim: int):
    """Refuse (one VolumeError line) a level's scale or translation `value` that is not one number per axis."""
    raise VolumeError(f"{path.name}: OME-Zarr level {name!r} has {kind} {_short(value)} in {owner} "
                      f"coordinateTransformations, not a list of "
                      f"{ndim} finite numbers (one per axis); write it again with one number per axis")


def _translation(value, ndim: int, path: Path, name: str, owner: str) -> list[float]:
    """`value` as `ndim` finite floats, or one VolumeError line naming the level and the fix."""
    numbers = isinstance(value, (list, tuple)) and len(value) == ndim and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    if not numbers:
        _refuse_not_per_axis(path, name, "translation", value, owner, ndim)
    return [float(v) for v in value]
