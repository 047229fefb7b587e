"""core/joined.py: meshes end to end, each one's faces numbering its own vertices in the joined arrays."""
import numpy as np
import pytest

from isoscope.core.joined import joined


def test_faces_point_at_the_same_points_after_joining():
    rng = np.random.default_rng(3)
    parts = []
    for n in (4, 7, 5):
        verts = rng.normal(size=(n, 3)).astype(np.float32)
        faces = rng.integers(0, n, size=(2 * n, 3)).astype(np.int32)
        parts.append((verts, faces, -verts, rng.random(n).astype(np.float32)))
    verts, faces, normals, values = joined(parts)
    assert faces.dtype == np.int32 and verts.dtype == np.float32 and len(verts) == 16 and len(values) == 16
    triangles = np.concatenate([part[0][part[1]] for part in parts])   # each part's triangles as points
    np.testing.assert_array_equal(verts[faces], triangles)
    np.testing.assert_array_equal(normals, -verts)


def test_faces_type_is_checked_against_the_vertex_count():
    verts = np.zeros((3, 3), np.float32)
    assert joined([(verts, [[0, 1, 2]])], np.int64)[1].dtype == np.int64
    with pytest.raises(ValueError, match="do not fit int8"):
        joined([(np.zeros((200, 3)), [[0, 1, 2]])], np.int8)
    with pytest.raises(ValueError, match="at least one"):
        joined([])
