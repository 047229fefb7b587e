"""One closed surface per label of an integer label volume (a segmentation), neighbours sharing vertices.

    surfaces = isoscope.label_surfaces(labels, spacing=(1, 1, 1))   # {label: (verts, faces, normals)}

How, and why so: each label's inside is ``labels == label``.  Its surface is our marching cubes
(GPU, or the byte-identical numpy extractor) run on that label's indicator field (1 inside, 0
outside) at the fixed level 0.5, as VTK's discrete flying edges and the zmesh package do.  At
that level every vertex lies at the midpoint of a grid edge whose two ends differ, whichever the
labels at its ends: where labels A and B touch, A's surface and B's surface put a vertex at the
midpoint of the same edges, so they share those vertices.  Positions are rebuilt from the
grid edge (twice the index is an integer) with the same arithmetic for every label, so shared
vertices are bit-identical, not merely close.  This runs on our pipeline rather than a
separate multi-label mesher, so the GPU and numpy give the same meshes and share the case table.

Each label is extracted from its bounding box grown by one voxel of outside on every side,
so the surface closes at the volume's border too, and only the voxels near a label are sent
to the extractor.  The labels and their boxes are found in one pass by scipy's find_objects
(numpy alone needed a bincount per plane per axis: 6x slower, and longer code).

Marching cubes at 0.5 cuts the corners of the voxel staircase, so a label's enclosed volume is
a little below its voxel count times the voxel volume.  The case table here is `label_table`:
the extractor's loops (the same segments on every cell face), each folded outwards to enclose
the most volume, which gives back about half of what convex corners lose.  Enclosed volume
against voxel volume, 40 balls 10 voxels across at random sub-voxel centres: -0.8 to -1.3%
(-2.2 to -2.5% with the extractor's angle-folded table; zmesh -1.8 to -2.0%); 0.1% at 20
across.  On a folded segmentation the outward folds overfill the concave places instead: the
MNI template's grey and white matter (bench_labels.py) +0.7% and +0.4% (angle-folded: +0.04% and
-0.25%), within the same 2%.  A fold chosen per cell to match the inside corners' share of the
cell (k/8) was tried too: balanced on folded shapes, but -1.8 to -2.0% on those balls.  The
price of outward folds: where two labels touch, each one's folds lean into the other inside the
cells whose loops have five or more sides (up to half a voxel in the worst case of the table),
so the two surfaces cross there; their shared vertices stay identical, and each surface alone is
closed and 2-manifold.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import validation
from .core.case_table import label_table
from .core.joined import joined
from .errors import InputError, IsoscopeError

# Labels from 1 up to this are their own ids for scipy's find_objects; others (negative, or
# wide such as 32-bit ids) are numbered 1.. first, by sorting.
DIRECT_LABELS = 1 << 16


def check_labels(labels) -> np.ndarray:
    """`labels` as a 3-D integer array; a one-line ValueError naming the problem and the fix."""
    if not isinstance(labels, np.ndarray):
        try:
            labels = np.asarray(labels)
        except Exception as exc:
            raise InputError(f"labels must be a 3-D integer array; got {type(labels).__name__} ({exc})") from None
    if labels.dtype == bool:
        labels = labels.view(np.uint8)
    if labels.dtype.kind not in "iu":
        raise InputError(f"labels must be an integer array (one whole number per voxel); got {labels.dtype}: "
                         "cast it, e.g. labels.astype(np.int32), if its values are whole numbers")
    if labels.ndim != 3:
        raise InputError(f"labels must be 3-D; got shape {labels.shape}")
    if 0 in labels.shape:
        raise InputError(f"labels has an empty axis (shape {labels.shape}); pass at least one voxel per axis")
    return labels


def label_boxes(labels: np.ndarray) -> tuple[np.ndarray, list[tuple[int, int, tuple[slice, ...]]]]:
    """(ids, [(label, its id in ids, its index box as slices), ...] in label order) for every non-zero
    label, the boxes found in one pass (scipy's find_objects).  `ids` is `labels` itself when its
    labels are small and positive; otherwise the labels numbered 1, 2, ... in order."""
    from scipy.ndimage import find_objects
    low, high = int(labels.min()), int(labels.max())
    if low >= 0 and high <= DIRECT_LABELS:
        boxes = find_objects(labels, max_label=high) if high else []
        return labels, [(k + 1, k + 1, box) for k, box in enumerate(boxes) if box is not None]
    values = np.unique(labels)
    values = values[values != 0]
    ids = np.searchsorted(values, labels).astype(np.int32) + 1
    ids[labels == 0] = 0
    return ids, [(value.item(), k + 1, box) for k, (value, box) in enumerate(zip(values, find_objects(ids)))]


def label_surfaces(labels, *, spacing=(1.0, 1.0, 1.0), backend="auto", max_labels: int | None = None):
    """One closed surface per non-zero label of a 3-D integer array, neighbours sharing vertices.

    Each label's surface is marching cubes of its indicator field (1 inside, 0
    outside) at the level 0.5, as VTK's discrete flying edges [1]_ does, with a
    case table whose loops fold outwards (`isoscope.core.case_table.label_table`,
    after [2]_); see the module docstring for why.

    Parameters
    ----------
    labels : (I, J, K) array_like of int
        A segmentation: one label per voxel, 0 for the background.  A bool array
        counts as labels 0 and 1.
    spacing : tuple of 3 floats, default (1.0, 1.0, 1.0)
        Voxel size along axes 0, 1, 2; vertices are scaled by it.
    backend : {"auto", "gpu", "cpu", "numpy"}, default "auto"
        As for `marching_cubes`; all give the same meshes.
    max_labels : int, optional
        With it, more labels than that raise `TooManyLabels` before any is
        extracted.

    Returns
    -------
    surfaces : dict
        ``{label: (verts, faces, normals)}`` in label order: `verts` (N, 3)
        float32 in array-index order times `spacing`, `faces` (M, 3) int32,
        `normals` (N, 3) float32 unit vectors pointing out of the label.

    Raises
    ------
    ValueError
        `labels` is not a 3-D integer array, or the backend is unknown.
    TooManyLabels
        More labels than `max_labels` (a ValueError too).

    See Also
    --------
    isoscope.marching_cubes
        The surface of one level of a scalar field.
    isoscope.isosurface
        These surfaces as one ``trimesh.Trimesh`` (``labels=True``).

    Notes
    -----
    Each surface is closed and 2-manifold, wound counter-clockwise seen from
    outside, even where its label touches the volume's border.  At level 0.5
    every vertex lies at the midpoint of its grid edge, so where two labels
    touch their surfaces have the same vertices on the common boundary, equal to
    the last bit.

    There is no ``topology`` here, nor smoothing, tetrahedra or sharp features
    (every door refuses them with a label map): on a 0/1 indicator at 0.5 each
    ambiguous face's bilinear saddle sits exactly at the level, where the
    trilinear interpolant's level set crosses itself and has no topology of its
    own to follow; the label table's rule (each loop folds outwards) decides it.

    References
    ----------
    .. [1] W. Schroeder, R. Maynard and B. Geveci, "Flying edges: a
       high-performance scalable isocontouring algorithm", IEEE Symposium on
       Large Data Analysis and Visualization (LDAV), 33-40, 2015.
    .. [2] C. Montani, R. Scateni and R. Scopigno, "A modified look-up table for
       implicit disambiguation of Marching Cubes", The Visual Computer 10(6),
       353-355, 1994.

    Examples
    --------
    Two 3 x 3 x 3 blocks side by side:

    >>> import numpy as np
    >>> import isoscope
    >>> labels = np.zeros((8, 8, 8), np.int32)
    >>> labels[1:4, 1:4, 1:4] = 1
    >>> labels[4:7, 1:4, 1:4] = 2
    >>> surfaces = isoscope.label_surfaces(labels, backend="cpu")
    >>> sorted(surfaces)
    [1, 2]
    >>> [(len(verts), len(faces)) for verts, faces, normals in surfaces.values()]
    [(54, 104), (54, 104)]

    They share the nine vertices of the face between them, at index 3.5 along axis 0:

    >>> shared = {tuple(v) for v in surfaces[1][0].tolist()} & {tuple(v) for v in surfaces[2][0].tolist()}
    >>> len(shared), {v[0] for v in shared}
    (9, {3.5})
    """
    labels = check_labels(labels)
    spacing = np.asarray(validation.as_spacing(spacing, labels.shape), np.float64)
    ids, boxes = label_boxes(labels)
    if max_labels is not None and len(boxes) > max_labels:
        raise TooManyLabels(len(boxes), max_labels)
    extract = _extractor(backend)
    surfaces = {}
    for value, key, box in boxes:
        indicator = np.pad((ids[box] == key).view(np.uint8), 1)
        local, faces, normals = extract(indicator)
        # Twice a midpoint's index is a whole number: exact in float32 at spacing 1.
        doubled = np.rint(local * 2).astype(np.int64) + 2 * (np.array([b.start for b in box]) - 1)
        verts = (doubled * (spacing / 2)).astype(np.float32)
        normals = normals / spacing  # a gradient in index units, into physical units
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        surfaces[value] = (verts, faces, normals.astype(np.float32))
    return surfaces


def labels_of(volume) -> np.ndarray:
    """A loaded `Volume`'s data as labels: integers as they are, floats only when every value is whole
    (readers such as nibabel hand back scaled segmentations as floats), then as the narrowest integer
    type that holds their range.  Checked a block at a time (validation.blocks, as the value scan): no
    float-sized temporaries of the whole."""
    data = volume.data
    if data.dtype.kind == "f":
        for block in validation.blocks(data.shape, data.dtype.itemsize):
            slab = np.asarray(data[block])
            fractional = slab != np.round(slab)
            if fractional.any():
                first = tuple(int(i) + part.start for i, part in zip(np.argwhere(fractional)[0], block))
                raise InputError(f"{volume.name} is not a label map: it has fractional values (e.g. "
                                 f"{data[first]:g} at index {first}); leave out --labels to draw an isosurface")
        low, high = volume.value_range
        if not (-LARGEST_FLOAT_LABEL <= low and high <= LARGEST_FLOAT_LABEL):   # 1e30 cast to int64 is garbage
            value = low if low < -LARGEST_FLOAT_LABEL else high
            raise InputError(f"{volume.name} is not a label map: it has the value {value:g}, past the largest "
                             f"label a float can number exactly ({LARGEST_FLOAT_LABEL:,}); leave out --labels to "
                             "draw an isosurface")
        data = data.astype(_narrowest_int(int(low), int(high)))
    return data


LARGEST_FLOAT_LABEL = 2**53   # float64 holds every whole number up to this one


class NotALabelMap(IsoscopeError, ValueError):
    """--labels given a volume that looks like a scan (its values vary from voxel to voxel)."""


def refuse_a_scan(volume, force: bool = False, override: str = "--force-labels") -> None:
    """NotALabelMap, before anything is extracted or written, where `volume` looks like a scan
    (`looks_like_a_scan`) and not `force`: an 8-bit MRI has at most 255 values, under any label limit, and
    `export --labels` wrote 224 meshes (713 MB) of it.  `override` is how the caller's user says force."""
    scan = None if force else looks_like_a_scan(volume.data)
    if scan is not None:
        raise NotALabelMap(f"{volume.name} looks like a scan, not a label map: {scan}; leave out --labels to draw "
                           f"an isosurface, or pass {override} if it is a label map")


FLAT_SHARE = 0.5
"""A label map's neighbouring voxels inside its labels mostly hold the same label (a segmentation fills
flat regions: 0.97 on FreeSurfer- and TotalSegmentator-like maps, 0.975 on 3,000 small cells, 1.0 on a
mask); a scan's mostly differ (0.02 on a CT, 0.09 on the MNI T1, 0.05 on its grey-matter map)."""
PLANE_PAIRS = 12   # pairs of neighbouring planes looked at along each axis
MIN_PAIRS = 1000   # fewer non-zero neighbour pairs than this: too little to tell, taken as labels


def looks_like_a_scan(data) -> str | None:
    """Why `data` looks like a scan rather than a label map (in words), or None.  Reads PLANE_PAIRS pairs
    of neighbouring planes along each axis (basic slices: a memory map or a dask array reads only them),
    and counts how often two neighbouring non-zero voxels hold the same value."""
    if data.dtype.kind == "b":
        return None
    same = both = 0
    for axis in range(3):
        n = data.shape[axis]
        for i in np.unique(np.linspace(0, n - 2, PLANE_PAIRS).astype(int)) if n > 1 else ():
            index = (slice(None),) * axis + (slice(int(i), int(i) + 2),)
            pair = np.moveaxis(np.asarray(data[index]), axis, 0)
            inside = (pair[0] != 0) & (pair[1] != 0)
            both += int(np.count_nonzero(inside))
            same += int(np.count_nonzero(inside & (pair[0] == pair[1])))
    if both < MIN_PAIRS or same >= FLAT_SHARE * both:
        return None
    return (f"neighbouring voxels hold the same value in only {same / both:.0%} of places, where a segmentation's "
            "labels fill flat regions")


def _narrowest_int(low: int, high: int) -> np.dtype:
    for kind in ((np.uint8, np.uint16, np.uint32) if low >= 0 else ()) + (np.int16, np.int32, np.int64):
        info = np.iinfo(kind)
        if info.min <= low and high <= info.max:
            return np.dtype(kind)
    return np.dtype(np.int64)


DEFAULT_MAX_LABELS = 255
"""`isoscope export --labels` writes at most this many labels (a file each) unless --max-labels says more:
a scan opened with --labels by mistake has a label per grey value (224 files, 713 MB, of one MRI)."""


class TooManyLabels(IsoscopeError, ValueError):
    """More non-zero labels than the limit; raised before any surface is made."""

    def __init__(self, count: int, limit: int):
        super().__init__(f"labels has {count} distinct non-zero labels, more than max_labels={limit}; "
                         f"pass max_labels={count} (or None) if it is a label map")
        self.count, self.limit = count, limit


MAX_HINTED_LABELS = 64
"""An 8/16-bit integer volume with this many distinct non-zero values or fewer looks like a label map."""


def label_count_hint(data) -> int:
    """How many non-zero labels `data` holds if it looks like a label map (an 8- or 16-bit integer
    array with 1..MAX_HINTED_LABELS distinct non-zero values, counted by one bincount), else 0.
    The viewer offers to show it as labels; it never switches by itself, since a binary mask or a
    coarsely quantised scan is an integer volume with few values too."""
    if not isinstance(data, np.ndarray) or data.dtype.kind not in "iu" or data.dtype.itemsize > 2:
        return 0
    values = data.ravel()
    shift = 0
    if data.dtype.kind == "i":   # bincount counts from 0: shift signed values up by the type's half range
        shift = 1 << (8 * data.dtype.itemsize - 1)
        values = values.astype(np.int32) + shift
    counts = np.bincount(values)
    if shift < len(counts):
        counts[shift] = 0   # the background
    labels = int(np.count_nonzero(counts))
    return labels if 1 <= labels <= MAX_HINTED_LABELS else 0


def _extractor(backend: str):
    """indicator -> (verts, faces, normals) at level 0.5: one GL context found once for all labels
    (asking for the current context costs a few ms each time), else the compiled CPU extractor ("cpu",
    or "auto" with no GL or a software renderer: gpu.context's one_shot_backend) or the numpy one ("numpy")."""
    from .gpu.context import current_or_standalone, one_shot_backend
    from .one_shot import BACKENDS
    if backend not in BACKENDS:
        raise InputError(f"backend {backend!r} is not one of {BACKENDS}")
    table = label_table()
    if backend == "numpy":
        from .cpu.cubes import marching_cubes_reference
        return lambda indicator: marching_cubes_reference(indicator.astype(np.float32), 0.5, table=table)[:3]
    if backend == "cpu" or (backend == "auto" and one_shot_backend() == "cpu"):
        from .cpu.compiled import marching_cubes_compiled
        return lambda indicator: marching_cubes_compiled(indicator, 0.5, table=table)[:3]  # uint8, read in place
    from .gpu.cubes import Extractor
    ctx = current_or_standalone()

    def extract(indicator):
        """The mesh (verts, faces, normals) of one label's 0/1 indicator at 0.5, by the GPU extractor in the shared
        context."""
        with Extractor(indicator, ctx=ctx, table=table) as extractor:
            extractor.extract(0.5)
            return extractor.read_mesh()[:3]
    return extract


def label_colors(count: int) -> np.ndarray:
    """(count, 3) float RGB in 0..1, distinct colours for `count` labels, from the cmap library:
    the qualitative 'tab20' map for up to 20 labels (its ten strong hues first, then their light
    partners, so neighbouring label numbers differ in hue), 'glasbey' (255 distinct colours) beyond,
    then round again."""
    from cmap import Colormap
    if count <= 20:
        table = Colormap("tab20").lut()[np.r_[0:20:2, 1:20:2], :3]
    else:
        table = Colormap("glasbey").lut()[1:, :3]  # glasbey starts with white: skip it
    return table[np.arange(count) % len(table)]


def label_file(path, label) -> Path:
    """Where `export --labels` writes one label's mesh: `stem_label<N>.ext` beside `path`."""
    path = Path(path)
    return path.with_name(f"{path.stem}_label{label}{path.suffix}")


def check_label_output(path, one_file: bool) -> None:
    """A one-line ValueError, before any work, for a name `write_label_meshes` cannot write."""
    from .io.export import COLOR_FORMATS, mesh_format
    mesh_format(path)
    folder = Path(path).parent
    if not folder.is_dir():
        raise InputError(f"the folder {folder} for {Path(path).name} does not exist; create it or write elsewhere")
    if one_file and Path(path).suffix.lower() not in COLOR_FORMATS:
        raise InputError(f"--one-file needs a format that carries vertex colours ({', '.join(COLOR_FORMATS)}); "
                         f"rename {Path(path).name}, or leave out --one-file for a file per label")


def write_label_meshes(volume, path, *, one_file: bool = False, world: bool = True,
                       max_labels: int | None = DEFAULT_MAX_LABELS) -> list[tuple[Path, int, int]]:
    """Write `volume`'s label surfaces: a file per label (`label_file`), or with `one_file` one PLY/GLB
    holding them all, each vertex in its label's colour.  Returns (path, vertices, triangles) per file.
    Each file is written atomically; the mesh is in the volume's world space where it has one.
    More labels than `max_labels` (None: no limit) raise `TooManyLabels` before anything is written."""
    from .io.export import in_volume_space
    check_label_output(path, one_file)
    surfaces = label_surfaces(labels_of(volume), spacing=volume.spacing, max_labels=max_labels)
    if not surfaces:
        raise InputError(f"{volume.name} has no non-zero labels, so no surface to write; leave out --labels "
                         "to export an isosurface")
    placed = {label: in_volume_space(volume, *mesh, world=world) for label, mesh in surfaces.items()}
    meshes = {label: mesh[:3] for label, mesh in placed.items()}
    space = next(iter(placed.values()))[3]
    return write_labelled(path, meshes, label_colors(len(meshes)), space, one_file)


def write_labelled(path, meshes: dict, colors, space: str, one_file: bool) -> list[tuple[Path, int, int]]:
    """Write label meshes ``{label: (verts, faces, normals)}`` (already placed in `space`): a file per
    label (`label_file`), or with `one_file` one PLY/GLB with each vertex in its label's colour
    (`colors`: (labels, 3) RGB in 0..1, in the meshes' order).  Returns (path, vertices, triangles)."""
    from .io.export import write_mesh
    if not one_file:
        return [(write_mesh(label_file(path, label), *mesh, space=space), len(mesh[0]), len(mesh[1]))
                for label, mesh in meshes.items()]
    verts, faces, normals, rgba = coloured_join(list(meshes.values()), colors)
    return [(write_mesh(path, verts, faces, normals, rgba, space=space), len(verts), len(faces))]


def coloured_join(meshes, colors) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Label meshes [(verts, faces, normals), ...] joined into one (int64 faces), and each vertex's colour:
    its label's (`colors`: (labels, 3) RGB in 0..1, in the meshes' order) as (N, 4) RGBA uint8, opaque."""
    colors = np.round(np.asarray(colors, float).reshape(-1, 3) * 255).astype(np.uint8)
    verts, faces, normals = joined(meshes, np.int64)
    rgba = np.repeat(np.column_stack([colors, np.full(len(colors), 255, np.uint8)]),
                     [len(mesh[0]) for mesh in meshes], axis=0)
    return verts, faces, normals, rgba
