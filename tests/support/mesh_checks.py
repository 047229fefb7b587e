"""Independent facts about triangle meshes, computed from the arrays alone."""
from __future__ import annotations

import numpy as np


def directed_edges(faces):
    return np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])


def edge_use_counts(faces):
    """Map undirected edge -> number of triangles using it."""
    undirected = np.sort(directed_edges(faces), axis=1)
    edges, counts = np.unique(undirected, axis=0, return_counts=True)
    return edges, counts


def assert_closed_manifold(faces):
    """Every edge in exactly two triangles, traversed in opposite directions (consistent winding)."""
    _, counts = edge_use_counts(faces)
    assert counts.size and (counts == 2).all(), f"edge use counts: {np.bincount(counts)}"
    directed = directed_edges(faces)
    assert len(np.unique(directed, axis=0)) == len(directed), "some edge is traversed twice the same way"


def triangle_areas(verts, faces):
    tri = verts[faces].astype(np.float64)
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


def signed_volume(verts, faces):
    tri = verts[faces].astype(np.float64)
    return np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0


def euler_characteristic(verts, faces):
    edges, _ = edge_use_counts(faces)
    return len(np.unique(faces)) - len(edges) + len(faces)


def sign_changing_edges(volume, level, descent=True):
    """Grid edges whose two samples are on different sides of the level (ties count as inside)."""
    inside = volume >= level if descent else volume <= level
    return int(sum(np.count_nonzero(np.diff(inside.astype(np.int8), axis=a)) for a in range(3)))


def assert_clean_geometry(verts, faces):
    """No zero-area triangle and no two vertices at one position."""
    assert len(faces) == 0 or triangle_areas(verts, faces).min() > 0
    assert len(np.unique(verts, axis=0)) == len(verts), "two vertices share a position"


def assert_holes_only_on_the_border(verts, faces, shape):
    """Manifold with boundary: every edge in one or two triangles, and both ends of each
    once-used edge on one plane of the volume's border (no hole inside the volume)."""
    edges, counts = edge_use_counts(faces)
    assert set(np.unique(counts)) <= {1, 2}
    ends = verts[edges[counts == 1]]  # (E, 2, 3)
    upper = (np.array(shape) - 1).astype(np.float32)
    assert (np.isclose(ends, 0.0) | np.isclose(ends, upper)).all(axis=1).any(axis=1).all()


def assert_same_mesh(gpu, cpu):
    (gv, gf, gn, gval), (cv, cf, cn, cval) = gpu, cpu
    assert gf.dtype == np.int32 and gv.dtype == np.float32
    np.testing.assert_array_equal(gf, cf)
    np.testing.assert_allclose(gv, cv, rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(gn, cn, atol=1e-5)
    np.testing.assert_allclose(gval, cval, rtol=1e-5, atol=1e-5)


def read_ply(path):
    """A minimal reader of binary little-endian PLY with float x y z nx ny nz and uchar-int faces."""
    data = path.read_bytes()
    header_end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:header_end].decode("ascii").splitlines()
    assert header[:2] == ["ply", "format binary_little_endian 1.0"]
    counts = {line.split()[1]: int(line.split()[2]) for line in header if line.startswith("element")}
    assert [line for line in header if line.startswith("property")] == [
        "property float x", "property float y", "property float z",
        "property float nx", "property float ny", "property float nz",
        "property list uchar int vertex_indices"]
    vertex_bytes = counts["vertex"] * 24
    vertices = np.frombuffer(data, "<f4", counts["vertex"] * 6, header_end).reshape(-1, 6)
    faces = np.frombuffer(data[header_end + vertex_bytes:],
                          np.dtype([("n", "u1"), ("i", "<i4", 3)]), counts["face"])
    assert header_end + vertex_bytes + 13 * counts["face"] == len(data)
    return vertices[:, :3], vertices[:, 3:], faces["n"], faces["i"]


def triangles(meshes) -> set:
    """Each triangle as the positions of its corners, turned so the least comes first (winding kept)."""
    found = set()
    for verts, faces in meshes:
        corners = [tuple(map(tuple, verts[face])) for face in faces]
        for a, b, c in corners:
            turns = [(a, b, c), (b, c, a), (c, a, b)]
            found.add(min(turns))
    return found


def edge_uses(tris: set) -> dict:
    """How many triangles use each undirected edge (corners as positions)."""
    uses = {}
    for tri in tris:
        for i in range(3):
            edge = frozenset((tri[i], tri[(i + 1) % 3]))
            uses[edge] = uses.get(edge, 0) + 1
    return uses
