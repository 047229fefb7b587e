"""mask= (scikit-image's keyword): triangles only in the cells the mask keeps."""
from __future__ import annotations

import numpy as np
import pytest
from skimage import measure
from support.mesh_checks import edge_use_counts

import isoscope


def sphere(n=24):
    index = np.indices((n, n, n)).astype(np.float32)
    return np.sqrt(((index - np.array([11.3, 11.6, 10.9])[:, None, None, None]) ** 2).sum(axis=0))


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
def test_the_mask_keeps_the_cells_scikit_image_keeps(backend):
    volume = sphere()
    mask = np.zeros(volume.shape, bool)
    mask[:12] = True
    mask[:, :, 17:] = False
    verts, faces, normals, values = isoscope.marching_cubes(volume, 7.0, mask=mask, backend=backend)
    full = isoscope.marching_cubes(volume, 7.0, backend=backend)
    # A smooth sphere has no ambiguous cells, so every kept cell has scikit-image's triangle count.
    assert len(faces) == len(measure.marching_cubes(volume, 7.0, mask=mask)[1])
    assert 0 < len(faces) < len(full[1])
    # Every vertex is used, every triangle is one of the full mesh's, and the surface is open at the cut.
    assert np.array_equal(np.unique(faces), np.arange(len(verts)))
    full_triangles = {tuple(row) for row in np.round(full[0][full[1]].reshape(-1, 9), 5)}
    assert all(tuple(row) in full_triangles for row in np.round(verts[faces].reshape(-1, 9), 5))
    assert (edge_use_counts(faces)[1] == 1).any()
    # The mask and its complement part the full mesh.
    rest = isoscope.marching_cubes(volume, 7.0, mask=~mask, backend=backend)[1]
    assert len(faces) + len(rest) == len(full[1])


def test_marching_tetrahedra_takes_a_mask_too():
    volume = sphere(16)
    mask = np.zeros(volume.shape, bool)
    mask[8:] = True
    part = isoscope.marching_tetrahedra(volume, 5.0, mask=mask)[1]
    rest = isoscope.marching_tetrahedra(volume, 5.0, mask=~mask)[1]
    assert len(part) and len(rest)
    assert len(part) + len(rest) == len(isoscope.marching_tetrahedra(volume, 5.0)[1])


@pytest.mark.parametrize("call, mask, words", [
    (isoscope.marching_cubes, np.ones((3, 3, 3), bool), ["shape", "3x3x3"]),
    (isoscope.marching_tetrahedra, np.ones((4, 4, 3), bool), ["shape", "4x4x3"]),
    (isoscope.marching_cubes, np.ones((4, 4, 4), np.uint8), ["boolean"]),
])
def test_a_bad_mask_is_a_one_line_value_error(call, mask, words):
    with pytest.raises(ValueError) as error:
        call(np.arange(64, dtype=np.float32).reshape(4, 4, 4), 30.0, mask=mask)
    message = str(error.value)
    assert "\n" not in message and all(word in message for word in words)


def test_a_mask_with_smoothing_is_refused():
    with pytest.raises(ValueError, match="mask"):
        isoscope.marching_cubes(sphere(12), 4.0, mask=np.ones((12, 12, 12), bool), smooth=2)
