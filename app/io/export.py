"""Write a triangle mesh to disk in the format its file name says, through trimesh.

PLY (binary), OBJ, STL (binary), GLB (binary glTF) and OFF: what MeshLab, Blender,
ParaView, 3D Slicer, slicers for 3-D printing and web viewers open.  trimesh writes
them (a maintained library, not a hand-written writer); isoscope hands it the mesh
as it is (no merging or reordering), with its per-vertex normals where the format
carries them (PLY, OBJ, GLB; STL has face normals, OFF none).

A file is written to a temporary name beside the target and renamed over it only
once complete, so a failure (or Ctrl-C, or SIGTERM) never leaves half a file or harms
an existing one (see atomic.py: permissions, symbolic links, error messages).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from .atomic import signals_not_swallowed, write_atomically

FORMATS = {".ply": "ply", ".obj": "obj", ".stl": "stl", ".glb": "glb", ".off": "off"}


def mesh_format(path) -> str:
    """trimesh's file type for `path`'s extension; a one-line ValueError for any other."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        given = f"'{suffix}'" if suffix else "no extension"
        raise InputError(f"{Path(path).name}: {given} is not a mesh format isoscope writes; "
                         f"end the name in one of {', '.join(FORMATS)}")
    return FORMATS[suffix]


COLOR_FORMATS = (".ply", ".glb")  # the formats here that carry a colour per vertex


def space_comment(space: str) -> str:
    """The line that names a file's coordinate space (`in_volume_space`'s name for it)."""
    unit = {"RAS": " millimetres (world)", "LPS": " millimetres (world)",
            "OME-Zarr": " scale and translation, axes z y x, the file's units (world)"}.get(space, "")
    return f"isoscope mesh; vertex coordinates: {space}{unit}"


def mesh_bytes(file_type: str, verts, faces, normals, colors=None, comment: str | None = None) -> bytes:
    """The mesh encoded as `file_type` by trimesh; `colors`: (N, 4) uint8 RGBA per vertex, or None;
    `comment`: a line for the header of the formats that have comments (PLY, OBJ)."""
    import trimesh
    verts = np.asarray(verts, np.float32).reshape(-1, 3)
    normals = np.asarray(normals, np.float32).reshape(-1, 3)
    faces = np.asarray(faces).reshape(-1, 3)
    if not len(faces):
        raise InputError("the mesh is empty (no surface at this level); nothing written: pick a level "
                         "between the values inside and outside the object")
    if len(normals) != len(verts):
        raise InputError(f"{len(verts)} vertices but {len(normals)} normals; pass one normal per vertex")
    if len(faces) and (faces.min() < 0 or faces.max() >= len(verts)):
        raise InputError(f"face indices must lie in [0, {len(verts)}); got {faces.min()}..{faces.max()}")
    options = {"ply": {"encoding": "binary", "vertex_normal": True}, "obj": {"include_normals": True},
               "glb": {"include_normals": True}}.get(file_type, {})
    if comment and file_type == "obj":
        options["header"] = comment
    # trimesh catches BaseException in places (and carries on without what failed): a Ctrl-C there
    # would be swallowed and a wrong file written with exit 0. The guard hands it on as it returns.
    with signals_not_swallowed():
        mesh = trimesh.Trimesh(vertices=verts, faces=faces, vertex_normals=normals, vertex_colors=colors,
                               process=False, validate=False)
        data = mesh.export(file_type=file_type, **options)
    data = data.encode() if isinstance(data, str) else data
    if comment and file_type == "ply":  # a comment line may stand anywhere in the header: after `format`
        end_of_format = data.index(b"\n", data.index(b"\nformat ") + 1) + 1
        data = data[:end_of_format] + f"comment {comment}\n".encode("ascii") + data[end_of_format:]
    return data


def to_world(verts, faces, normals, spacing, index_to_world: np.ndarray):
    """The mesh moved from isoscope's units (array index x spacing) into a file's world space.

    Positions by the 4x4 index -> world matrix; normals by the inverse transpose of its linear
    part (so they stay perpendicular to the surface and point out of it); and where the matrix
    mirrors, each triangle's winding reversed, so triangles stay counter-clockwise seen from outside."""
    linear = np.asarray(index_to_world, np.float64)[:3, :3] / np.asarray(spacing, np.float64)
    offset = np.asarray(index_to_world, np.float64)[:3, 3]
    world_verts = (np.asarray(verts, np.float64) @ linear.T + offset).astype(np.float32)
    world_normals = np.asarray(normals, np.float64) @ np.linalg.inv(linear)
    world_normals /= np.maximum(np.linalg.norm(world_normals, axis=1, keepdims=True), 1e-30)
    faces = np.asarray(faces)
    if np.linalg.det(linear) < 0:
        faces = faces[:, ::-1]
    return world_verts, np.ascontiguousarray(faces), world_normals.astype(np.float32)


def in_volume_space(volume, verts, faces, normals, world: bool = True):
    """(verts, faces, normals, space name): the mesh (as extracted: array index x spacing) in `volume`'s world
    coordinates where its file defines them and `world` is asked for, else in index x spacing, moved by the
    volume's `origin` (a coarse view's of a pyramid level off the full level's grid; (0, 0, 0) for the rest)."""
    if world and volume.world is not None:
        matrix, space = volume.world
        return (*to_world(verts, faces, normals, volume.spacing, matrix), space)
    origin = getattr(volume, "origin", (0.0, 0.0, 0.0))
    if any(origin):
        verts = (np.asarray(verts, np.float64) + origin).astype(np.float32)
    return verts, faces, normals, "index x spacing"


def write_mesh(path, verts, faces, normals, colors=None, space: str | None = None) -> Path:
    """Write the mesh to `path` in the format of its extension, atomically; returns the path.
    `space` (RAS, LPS, index x spacing) is named in the header where the format has comments."""
    data = mesh_bytes(mesh_format(path), verts, faces, normals, colors, space and space_comment(space))
    return write_atomically(path, lambda out: out.write(data))
