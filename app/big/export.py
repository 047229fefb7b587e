"""The whole volume's mesh at one level, a chunk at a time, written to a mesh file: what `isoscope export
VOLUME --iso L --chunk N` writes, callable in any thread (the viewer's "Export full resolution..." runs it
on a worker, with progress and a stop).  The chunks are extracted on the CPU (a worker thread has no GL
context; the GPU gives the same faces), in memory bounded by a chunk (big/chunked.py)."""
from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path

from ..errors import IsoscopeError
from ..validation import as_gradient_direction, as_level
from .chunked import DEFAULT_CHUNK, as_chunks, marching_cubes_chunked


class Stopped(IsoscopeError):
    """The export was stopped before its file was written; nothing was written."""


def write_full_resolution(volume, level: float, out, *, gradient_direction: str | None = None,
                          chunk: int = DEFAULT_CHUNK, world: bool = True,
                          progress: Callable[[float, str], None] | None = None,
                          stop: threading.Event | None = None, topology: str = "montani") -> tuple[Path, int, int, str]:
    """Write the mesh of `volume` (a `Volume`: its data, spacing, world frame) at `level` to `out`, with
    `gradient_direction` the side taken as inside (default: the volume's own) and `topology` the ambiguous
    cells' rule; (path, vertices, triangles, the coordinates' name).  `progress(fraction, message)` hears each
    chunk; a set `stop` ends the work with Stopped before the file is written (writes are atomic: no half file
    either way)."""
    from ..io.export import in_volume_space, mesh_format, write_mesh
    mesh_format(out)   # an unknown extension refused before any work
    level = as_level(level, volume.value_range)
    descent = as_gradient_direction(gradient_direction or volume.gradient_direction)
    chunks = as_chunks(chunk, volume.data.shape)

    def report(fraction: float, message: str) -> None:
        """Hand a chunk's progress on; a set `stop` raises Stopped here, between chunks, before anything is written."""
        if stop is not None and stop.is_set():
            raise Stopped("the export was stopped; nothing was written")
        if progress is not None:
            progress(fraction, message)

    verts, faces, normals, _ = marching_cubes_chunked(volume.data, level, volume.spacing, descent, chunks,
                                                      progress=report, backend="cpu", topology=topology)
    report(1.0, "writing the mesh")
    verts, faces, normals, space = in_volume_space(volume, verts, faces, normals, world=world)
    path = write_mesh(out, verts, faces, normals, space=space)
    return path, len(verts), len(faces), space
