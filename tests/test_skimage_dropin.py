"""isoscope.marching_cubes beside skimage.measure.marching_cubes (issue 25, point 5): the same vertices, face
winding, normal direction and `values`, for both gradient directions, with spacing, step_size and a mask,
on a sphere, an ellipsoid, smoothed noise and a real-valued CT-like head.  Every fact is scikit-image's
own output, matched to ours vertex by vertex by position; only isoscope's own outward mesh
(`outward_marching_cubes`, what isosurface, export and the viewer use) keeps counter-clockwise triangles."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter
from scipy.spatial import cKDTree
from skimage import measure
from support.head_phantom import STEP, head_lps
from support.mesh_checks import assert_same_mesh, signed_volume

import isoscope
from isoscope.api import outward_marching_cubes

# voxels: our vertex and scikit-image's on the same grid edge interpolate alike, but ours keeps 1/256 of the edge
# off its ends (a sample within a hair of the level), where theirs may come closer
MATCH = 1.0 / 200


def _axes(shape):
    return np.meshgrid(*(np.linspace(-1, 1, n) for n in shape), indexing="ij")


def sphere():
    x, y, z = _axes((30, 30, 30))
    return np.sqrt(x * x + y * y + z * z).astype(np.float32), 0.62


def ellipsoid():
    x, y, z = _axes((34, 26, 22))
    return ((x / 0.9) ** 2 + (y / 0.6) ** 2 + (z / 0.45) ** 2).astype(np.float32), 0.8


def noise():
    rng = np.random.default_rng(25)
    return gaussian_filter(rng.standard_normal((26, 30, 22)), 1.5).astype(np.float32), 0.01


def ct_head():
    """The phantom head in CT-like units (0 air .. 1000 bone, its surface at 500) with scanner noise."""
    rng = np.random.default_rng(5)
    return (head_lps() + rng.normal(0.0, 15.0, head_lps().shape)).astype(np.float32), 500.0


VOLUMES = {"sphere": sphere, "ellipsoid": ellipsoid, "noise": noise, "ct-head": ct_head}


def options(kind, shape):
    if kind == "spacing":
        return {"spacing": STEP}
    if kind == "step_size":
        return {"step_size": 2}
    if kind == "mask":
        mask = np.zeros(shape, bool)
        mask[:, : shape[1] // 2 + 3] = True  # half the volume and a bit: the surface open where it leaves
        return {"mask": mask}
    return {}


def winding_normals(verts, faces):
    """Per vertex, the area-weighted sum of its triangles' normals as their winding says (right-hand rule)."""
    tri = verts[faces].astype(np.float64)
    face_normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    out = np.zeros((len(verts), 3))
    for corner in range(3):
        np.add.at(out, faces[:, corner], face_normals)
    return out / np.maximum(np.linalg.norm(out, axis=1, keepdims=True), 1e-30)


def matched(ours, theirs, spacing, step=1):
    """Index pairs (ours, theirs) of vertices at the same place, and the fraction of ours matched."""
    scale = np.asarray(spacing, np.float64) * step
    distance, index = cKDTree(theirs / scale).query(ours / scale)
    hit = distance < MATCH
    return np.flatnonzero(hit), index[hit], hit.mean()


@pytest.mark.parametrize("kind", ["plain", "spacing", "step_size", "mask"])
@pytest.mark.parametrize("direction", ["descent", "ascent"])
@pytest.mark.parametrize("name", sorted(VOLUMES))
def test_the_mesh_is_scikit_images(name, direction, kind):
    volume, level = VOLUMES[name]()
    kwargs = options(kind, volume.shape)
    ours = isoscope.marching_cubes(volume, level, gradient_direction=direction, backend="cpu", **kwargs)
    theirs = measure.marching_cubes(volume, level, gradient_direction=direction, **kwargs)
    spacing = kwargs.get("spacing", (1.0, 1.0, 1.0))

    mine, its, fraction = matched(ours[0], theirs[0], spacing, kwargs.get("step_size", 1))
    assert fraction == 1.0  # every vertex of ours is one of theirs (theirs adds Lewiner's cell centres)
    assert len(np.unique(its)) == len(mine)
    assert len(mine) >= 0.97 * len(theirs[0])

    # The same winding: signed volumes of one sign, and each vertex's triangles facing alike.
    # (Sizes differ a little where the tables split ambiguous cells apart, and on an open surface more.)
    assert np.sign(signed_volume(*ours[:2])) == np.sign(signed_volume(*theirs[:2])) != 0
    facing = (winding_normals(*ours[:2])[mine] * winding_normals(*theirs[:2])[its]).sum(axis=1)
    assert facing.mean() > 0.9

    # Normals point the way scikit-image's do (toward lower values, whichever the direction).
    assert (ours[2][mine] * theirs[2][its]).sum(axis=1).mean() > 0.9

    # values: scikit-image's, bit for bit, at every matched vertex.
    assert ours[3].dtype == np.float32
    assert np.array_equal(ours[3][mine], theirs[3][its])


@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_the_outward_mesh_is_the_same_mesh_wound_outward(direction):
    """isosurface, export, measurements and the viewer use the outward mesh: the drop-in's vertices, its
    triangles reversed (counter-clockwise seen from outside: a positive volume for either direction), and
    normals out of the object."""
    volume, level = sphere()
    if direction == "descent":
        volume = -volume
        level = -level
    drop_in = isoscope.marching_cubes(volume, level, gradient_direction=direction, backend="cpu")
    outward = outward_marching_cubes(volume, level, gradient_direction=direction, backend="cpu")
    assert np.array_equal(drop_in[0], outward[0])
    assert np.array_equal(drop_in[1], outward[1][:, ::-1])
    assert signed_volume(*outward[:2]) > 0 > signed_volume(*drop_in[:2])
    centre = (np.asarray(volume.shape) - 1) / 2
    radial = (outward[0] - centre) / np.linalg.norm(outward[0] - centre, axis=1, keepdims=True)
    assert (outward[2] * radial).sum(axis=1).min() > 0.9  # out of the ball
    flip = 1 if direction == "descent" else -1
    assert np.array_equal(drop_in[2], flip * outward[2])
    mesh = isoscope.isosurface(volume, level, gradient_direction=direction, backend="cpu")
    assert mesh.is_watertight and mesh.volume > 0


@pytest.mark.parametrize("backend", ["numpy", "gpu"])
def test_every_backend_gives_the_same_drop_in_mesh(backend):
    """The numpy reference's mesh is the compiled one's bit for bit; the GPU's within the rounding its
    own tests allow (assert_same_mesh), its faces and values exactly."""
    volume, level = ct_head()
    expected = isoscope.marching_cubes(volume, level, spacing=STEP, gradient_direction="ascent", backend="cpu")
    got = isoscope.marching_cubes(volume, level, spacing=STEP, gradient_direction="ascent", backend=backend)
    assert np.array_equal(got[1], expected[1]) and np.array_equal(got[3], expected[3])
    if backend == "gpu":
        assert_same_mesh(got, expected)
    else:
        assert all(np.array_equal(mine, theirs) for mine, theirs in zip(got, expected))


@pytest.mark.parametrize("backend", ["cpu", "gpu"])
def test_smoothing_keeps_each_vertex_its_values(backend):
    """Smoothing moves the vertices but not the faces: vertex i keeps the value of its grid edge (the GPU
    smooths in place, so its plain vertices are read before)."""
    volume, level = noise()
    plain = isoscope.marching_cubes(volume, level, backend=backend)
    smoothed = isoscope.marching_cubes(volume, level, backend=backend, smooth=3)
    assert not np.array_equal(plain[0], smoothed[0])
    assert np.array_equal(plain[3], smoothed[3])


def test_a_lazy_volume_in_chunks_gives_the_whole_volumes_values():
    """chunks= reads a dask array a box at a time, and the values a slab of planes at a time: the same."""
    da = pytest.importorskip("dask.array")
    rng = np.random.default_rng(3)
    volume = gaussian_filter(rng.standard_normal((150, 20, 18)), 2.0).astype(np.float32)  # three slabs
    whole = isoscope.marching_cubes(volume, 0.0, backend="cpu")
    stitched = isoscope.marching_cubes(da.from_array(volume, chunks=(40, 20, 18)), 0.0, chunks=40, backend="cpu")
    order_whole, order_stitched = np.lexsort(whole[0].T), np.lexsort(stitched[0].T)
    assert np.array_equal(whole[0][order_whole], stitched[0][order_stitched])
    assert np.array_equal(whole[3][order_whole], stitched[3][order_stitched])
    theirs = measure.marching_cubes(volume, 0.0)
    mine, its, fraction = matched(stitched[0], theirs[0], (1, 1, 1))
    assert fraction == 1.0 and np.array_equal(stitched[3][mine], theirs[3][its])


@pytest.mark.parametrize("backend", ["cpu", "gpu"])
def test_a_sharp_feature_vertex_takes_its_cells_spread(backend):
    """Feature vertices (Extended Marching Cubes) are no grid-edge vertices: each takes the spread of the
    cells it touches, as a plain vertex does of the cells next to its edge."""
    box = (np.abs(np.mgrid[-1:1:21j, -1:1:21j, -1:1:21j]).max(axis=0) - 0.45).astype(np.float32)
    plain = isoscope.marching_cubes(box, 0.0, gradient_direction="ascent", backend=backend)
    sharp = isoscope.marching_cubes(box, 0.0, gradient_direction="ascent", backend=backend, sharp_features=30)
    n_plain = len(plain[0])
    assert np.array_equal(sharp[3][:n_plain], plain[3])
    for vertex, value in zip(sharp[0][n_plain:], sharp[3][n_plain:]):
        cell = np.floor(vertex).astype(int)
        samples = box[cell[0]:cell[0] + 2, cell[1]:cell[1] + 2, cell[2]:cell[2] + 2]
        assert value >= (samples.max() - samples.min()) * (1 - 1e-6) > 0
