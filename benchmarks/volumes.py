"""The benchmark volumes of FIELD-NOTES.md, generated with numpy (float32, C order).

All three use iso level 0. Their triangle counts at 256^3 match the peers'
figures in FIELD-NOTES (sphere 392 k, gyroid 3.79 M, noise ~7.4 M), and the
sphere gives exactly 97,148 triangles at 128^3 in every peer:

- sphere: signed distance to a sphere of radius 0.8 sampled on linspace(-1, 1, n)
  per axis; negative inside, so gradient_direction="ascent".
- gyroid: sin x cos y + sin y cos z + sin z cos x on linspace(0, 6 * 2 pi, n)
  per axis (6 periods, end points included); "descent".
- noise: gaussian_filter(normal(0, 1), sigma=3) minus its mean, seed 0; "descent".

Each generator builds the field from 1-D axes by broadcasting, so the peak
memory is a small multiple of the volume (a 512^3 float32 volume is 512 MiB).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


def _axes(n: int, lo: float, hi: float):
    axis = np.linspace(lo, hi, n, dtype=np.float64)
    return axis[:, None, None], axis[None, :, None], axis[None, None, :]


def sphere(n: int) -> np.ndarray:
    x, y, z = (a.astype(np.float32) for a in _axes(n, -1.0, 1.0))
    field = x * x + y * y            # (n, n, 1)
    field = field + z * z            # (n, n, n) float32
    np.sqrt(field, out=field)
    field -= np.float32(0.8)
    return field


def gyroid(n: int) -> np.ndarray:
    x, y, z = _axes(n, 0.0, 6 * 2 * np.pi)
    sx, cx = np.sin(x), np.cos(x)
    sy, cy = np.sin(y), np.cos(y)
    sz, cz = np.sin(z), np.cos(z)
    field = (sx * cy).astype(np.float32)           # (n, n, 1)
    field = field + (sy * cz).astype(np.float32)   # (n, n, n)
    field += (sz * cx).astype(np.float32)
    return field


def noise(n: int, seed: int = 0) -> np.ndarray:
    from scipy.ndimage import gaussian_filter
    rng = np.random.default_rng(seed)
    field = gaussian_filter(rng.standard_normal((n, n, n), dtype=np.float32), sigma=3)
    field -= field.mean(dtype=np.float64).astype(np.float32)
    return field


# name -> (generator, gradient_direction): which side of level 0 is the object.
VOLUMES = {
    "sphere": (sphere, "ascent"),
    "gyroid": (gyroid, "descent"),
    "noise": (noise, "descent"),
}


# -- real scans shipped inside pip packages (no download at run time) ------------------------

class MissingVolume(RuntimeError):
    """A real volume whose package is not installed: the message names the fix."""


# name -> (package, path inside the installed package, gradient_direction, levels, what it is).
# Levels are in the file's own units; why these: benchmarks/README.md.
REAL_VOLUMES = {
    "mni-t1": ("nilearn", "datasets/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz", "descent",
               (60.0, 128.0, 160.0, 200.0), "MNI ICBM152 2009a T1 template, 1 mm, brain only"),
    "mni-gm": ("nilearn", "datasets/data/mni_icbm152_gm_tal_nlin_sym_09a_converted.nii.gz", "descent",
               (64.0, 128.0, 192.0), "MNI ICBM152 2009a grey-matter probability map, 1 mm"),
}


def real_volume_path(name: str) -> Path:
    """The file of a named real volume inside its installed package (the package is not imported)."""
    import importlib.util
    package, inner = REAL_VOLUMES[name][:2]
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise MissingVolume(f"{name}: the package {package} is not installed; "
                            f"run `pip install -e .[bench]` (it ships the file {inner})")
    path = Path(spec.submodule_search_locations[0]) / inner
    if not path.is_file():
        raise MissingVolume(f"{name}: {package} is installed but has no {inner}; "
                            f"install the version named in benchmarks/README.md")
    return path


def load_real(name: str) -> tuple[np.ndarray, tuple[float, float, float]]:
    """A named real volume as (C-order array in the file's dtype, voxel spacing per axis)."""
    import nibabel
    image = nibabel.load(real_volume_path(name))
    data = np.ascontiguousarray(np.asanyarray(image.dataobj))
    return data, tuple(float(z) for z in image.header.get_zooms()[:3])


# -- a CT-like torso, saved and read back as nibabel gives it ---------------------------------

CT_SHAPE = (512, 512, 400)
CT_SPACING = (0.8, 0.8, 1.0)
CT_LEVELS = (-300.0, 300.0)
"""Skin (air/soft tissue, -300 HU) and bone (300 HU): the two levels a CT user picks first."""


def ct_torso(shape=CT_SHAPE, seed: int = 0) -> np.ndarray:
    """A CT-like torso in Hounsfield units, int16, C order (x, y, z): air -1000 around an elliptic body of
    soft tissue (40) with a fat rim (-100), two lungs (-850) with vessels, a spine of vertebrae (bone 700,
    a hollow marrow 250) and ribs every 25 mm, an aorta with contrast (250), and scanner noise (sigma 20
    HU) after a partial-volume blur.  No CT volume ships in a package (README), so one is made: what matters
    for speed is its size, its type, its empty air and the many small pieces bone gives at 300 HU."""
    from scipy.ndimage import gaussian_filter
    nx, ny, nz = shape
    x = np.linspace(-1, 1, nx, dtype=np.float32)[:, None]
    y = np.linspace(-1, 1, ny, dtype=np.float32)[None, :]
    rng = np.random.default_rng(seed)
    out = np.empty(shape, np.int16)
    body = (x / 0.85) ** 2 + (y / 0.62) ** 2
    lung_l = ((x + 0.38) / 0.27) ** 2 + ((y + 0.02) / 0.38) ** 2
    lung_r = ((x - 0.38) / 0.27) ** 2 + ((y + 0.02) / 0.38) ** 2
    vertebra = (x / 0.1) ** 2 + ((y - 0.36) / 0.09) ** 2
    marrow = (x / 0.07) ** 2 + ((y - 0.36) / 0.06) ** 2
    aorta = ((x + 0.05) / 0.06) ** 2 + ((y - 0.18) / 0.06) ** 2
    ring = np.sqrt((x / 0.76) ** 2 + (y / 0.54) ** 2)
    vessels = gaussian_filter(rng.standard_normal((nx, ny)).astype(np.float32), 3)
    for k in range(nz):
        z = k / max(nz - 1, 1)
        plane = np.full((nx, ny), -1000.0, np.float32)
        plane[body < 1.0] = -100.0
        plane[body < 0.88] = 40.0
        lungs = (lung_l < 1.0) | (lung_r < 1.0)
        if 0.15 < z < 0.9:
            plane[lungs] = -850.0
            plane[lungs & (np.abs(vessels) < 0.004 + 0.002 * np.sin(9 * z))] = 30.0
        disc = (k % 32) < 26  # vertebrae with discs between them
        plane[vertebra < 1.0] = 700.0 if disc else 80.0
        plane[(marrow < 1.0) & disc] = 250.0
        if (k % 25) < 6 and z > 0.1:  # a rib pair
            plane[(np.abs(ring - 0.93) < 0.03) & (y < 0.45)] = 650.0
        plane[aorta < 1.0] = 250.0
        out[:, :, k] = np.clip(gaussian_filter(plane, 1.2) + rng.normal(0, 20, plane.shape), -1024, 3071)
    return out


def ct_torso_nifti(folder: Path, shape=CT_SHAPE) -> Path:
    """ct_torso written once as `folder/ct_torso_AxBxC.nii` (int16, CT_SPACING; made again if missing)."""
    import nibabel
    path = Path(folder) / f"ct_torso_{'x'.join(map(str, shape))}.nii"
    if not path.is_file():
        image = nibabel.Nifti1Image(ct_torso(shape), np.diag([*CT_SPACING, 1.0]))
        image.header.set_data_dtype(np.int16)
        part = path.with_suffix(".part.nii")
        nibabel.save(image, part)
        part.replace(path)
    return path


def as_nibabel_gives(path: Path) -> tuple[np.ndarray, tuple[float, float, float]]:
    """The array exactly as a nibabel user has it: `np.asarray(nibabel.load(path).dataobj)` (Fortran order,
    the file's dtype), and the voxel size."""
    import nibabel
    image = nibabel.load(path)
    return np.asarray(image.dataobj), tuple(float(z) for z in image.header.get_zooms()[:3])


# -- a big memory-mapped volume, written a slab at a time ----------------------------------------

def smooth_memmap(folder: Path, n: int = 1024, slab: int = 32) -> Path:
    """`folder/smooth_N^3.npy`, an N^3 uint8 `.npy` made once (kept; made again if missing) with
    np.lib.format.open_memmap a slab of `slab` planes at a time, so making it takes a few slabs of memory:
    a ball (value 200 at the centre, 100 at radius ~0.53 of the half-side) with a ripple of 30 over it.
    Level 100 gives a closed, wrinkled surface of a few million triangles at 1024^3."""
    path = Path(folder) / f"smooth_{n}x{n}x{n}.npy"
    if path.is_file():
        return path
    Path(folder).mkdir(parents=True, exist_ok=True)
    part = path.with_suffix(".part.npy")
    out = np.lib.format.open_memmap(part, mode="w+", dtype=np.uint8, shape=(n, n, n))
    axis = np.linspace(-1, 1, n, dtype=np.float32)
    y, z = axis[None, :, None], axis[None, None, :]
    for start in range(0, n, slab):
        x = axis[start:start + slab, None, None]
        field = 200 * np.exp(-(x * x + y * y + z * z) / 0.4) + 30 * np.sin(6 * x) * np.sin(6 * y) * np.sin(6 * z)
        out[start:start + slab] = np.clip(field + 20, 0, 255).astype(np.uint8)
    out.flush()
    del out
    part.replace(path)
    return path


def smooth_pyramid(folder: Path, n: int = 1024, slab: int = 64) -> Path:
    """`folder/smooth_N^3.ome.zarr`, smooth_memmap's volume as an OME-Zarr image (NGFF 0.4, Zarr v2, 64^3
    chunks) with lower-resolution levels of 2x2x2 means (rounded, uint8), 3 at most, none under 16 samples a
    side, as pyramid writers make them; made once (kept), `slab` planes at a time."""
    import zarr
    path = Path(folder) / f"smooth_{n}x{n}x{n}.ome.zarr"
    if (path / ".zattrs").is_file():
        return path
    source = np.load(smooth_memmap(folder, n), mmap_mode="r")
    group = zarr.open_group(str(path), mode="w", zarr_format=2)
    level = group.create_array("0", shape=source.shape, chunks=(64, 64, 64), dtype="u1")
    for start in range(0, n, slab):
        level[start:start + slab] = source[start:start + slab]
    datasets = [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1.0] * 3}]}]
    while len(datasets) < 4 and min(level.shape) // 2 >= 16:
        half = tuple(s // 2 for s in level.shape)
        below = group.create_array(str(len(datasets)), shape=half, chunks=(64, 64, 64), dtype="u1")
        for start in range(0, half[0], slab):
            block = np.asarray(level[2 * start:2 * (start + slab)], dtype=np.float32)
            planes = block.shape[0] // 2
            block = block[:2 * planes, :2 * half[1], :2 * half[2]]
            means = block.reshape(planes, 2, half[1], 2, half[2], 2).mean(axis=(1, 3, 5))
            below[start:start + planes] = np.rint(means).astype(np.uint8)
        datasets.append({"path": str(len(datasets)), "coordinateTransformations": [
            {"type": "scale", "scale": [float(2 ** len(datasets))] * 3}]})
        level = below
    group.attrs["multiscales"] = [{"version": "0.4", "axes": [{"name": a, "type": "space"} for a in "zyx"],
                                   "datasets": datasets}]
    return path
