"""OME-Zarr images written for the tests with the zarr library: the levels' arrays and their multiscales
metadata (NGFF 0.4 under attrs for Zarr v2, 0.5 under attrs["ome"] for v3)."""
from __future__ import annotations

import numpy as np
import zarr

SPACE_AXES = [{"name": a, "type": "space"} for a in "zyx"]


def write_ome(path, levels, scales, axes=None, zarr_format: int = 2, chunk: int = 8, missing=()):
    """An OME-Zarr image at `path` whose level i is `levels[i]` (float32, chunks of `chunk` along the spatial
    axes, whole along any before them) with scale `scales[i]`; the levels in `missing` are named in the metadata
    but not written.  Returns the group."""
    group = zarr.open_group(str(path), mode="w", zarr_format=zarr_format)
    datasets = []
    for i, (data, scale) in enumerate(zip(levels, scales)):
        if i not in missing:
            chunks = tuple(data.shape[:-3]) + (chunk,) * min(data.ndim, 3)
            group.create_array(str(i), shape=data.shape, chunks=chunks, dtype="f4")[:] = data
        datasets.append({"path": str(i), "coordinateTransformations": [{"type": "scale", "scale": list(scale)}]})
    multiscales = [{"version": "0.4", "axes": SPACE_AXES if axes is None else axes, "datasets": datasets}]
    if zarr_format == 2:
        group.attrs["multiscales"] = multiscales
    else:
        group.attrs["ome"] = {"version": "0.5", "multiscales": multiscales}
    return group


def mean_levels(field: np.ndarray, count: int) -> list[np.ndarray]:
    """`field` and `count - 1` levels below it, each the 2x2x2 means of the one above (an odd last sample
    along an axis left out), as pyramid writers make them: not what striding the full level gives."""
    levels = [field]
    for _ in range(count - 1):
        data = levels[-1]
        n = [s // 2 for s in data.shape]
        levels.append(data[: 2 * n[0], : 2 * n[1], : 2 * n[2]].reshape(n[0], 2, n[1], 2, n[2], 2).mean(axis=(1, 3, 5)))
    return levels


def with_translations(path, translations, image=None):
    """Append a translation to each level's coordinateTransformations (after its scale, as NGFF orders them);
    `image`: the multiscale's own transformations."""
    group = zarr.open_group(str(path), mode="r+")
    key = "multiscales" if "multiscales" in group.attrs else "ome"
    attrs = dict(group.attrs[key]) if key == "ome" else None
    multiscales = attrs["multiscales"] if attrs is not None else group.attrs["multiscales"]
    for dataset, translation in zip(multiscales[0]["datasets"], translations):
        if translation is not None:
            dataset["coordinateTransformations"].append({"type": "translation", "translation": translation})
    if image is not None:
        multiscales[0]["coordinateTransformations"] = image
    if attrs is not None:
        attrs["multiscales"] = multiscales
        group.attrs["ome"] = attrs
    else:
        group.attrs["multiscales"] = multiscales
    return path


def half_block_translations(count: int, spacing=(1.0, 1.0, 1.0)) -> list[list[float]]:
    """Each of `count` levels of 2^k-block means' translation: its blocks' centres, (2^k - 1) / 2 full samples in
    (as ome-zarr-py writes them)."""
    return [[(2 ** k - 1) / 2 * s for s in spacing] for k in range(count)]
