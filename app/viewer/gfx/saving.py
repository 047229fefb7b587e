"""Saving what a `GpuScene` shows: the selected level's mesh at full resolution (closed at the border where the state
says so) or a label map's visible surfaces, read back from the GPU and written by io/export.py and labels.py in the
volume's world coordinates.  The panel asks through the state (`state.saving`); the scene's frame carries it out."""
from __future__ import annotations

from pathlib import Path

from ...labels import check_label_output, write_labelled
from ...one_shot import closed_mesh
from ..model.errors import ViewerError


def save_mesh(scene, path) -> None:
    """Write the surface `scene` shows (at full resolution) to `path`, in the format of its extension
    and the volume's world coordinates where its file defines them."""
    from ...io.export import COLOR_FORMATS, in_volume_space, write_mesh
    state, surface, options = scene.state, scene.surface, scene.options
    if state.labels:   # a label map: its visible labels, in one coloured file where the format can
        save_labels(scene, path, one_file=Path(path).suffix.lower() in COLOR_FORMATS)
        return
    if surface is None:
        raise ViewerError("no surface to save yet; open a volume first")
    if state.closed:   # capped at the border, watertight: the padded volume's mesh, as export --closed
        verts, faces, normals, _ = closed_mesh(state.volume, state.iso, options.cells, options.smooth,
                                               options.topology)
    else:
        if surface.shown_step != 1:  # a preview is on show: save the full mesh at its level
            surface.extract(state.iso, options)
        verts, faces, normals, _ = surface.shown.read_mesh()   # cubes' or tetrahedra's
    verts, faces, normals, space = in_volume_space(state.volume, verts, faces, normals)
    write_mesh(path, verts, faces, normals, space=space)
    state.error = None
    state.message = f"mesh saved: {path} ({len(faces):,} triangles, {space} coordinates)"


def save_labels(scene, path, one_file: bool = False) -> None:
    """The visible labels' surfaces `scene` shows, in the volume's world space: STEM_label<N>.EXT each, or with
    `one_file` all in `path` (PLY, GLB) with per-vertex colours."""
    from ...io.export import in_volume_space
    state = scene.state
    layers = [layer for _, layer in scene.labels.drawn(state.labels)]
    check_label_output(path, one_file)
    if not layers:
        raise ViewerError("no label is visible; tick the labels to save")
    placed = [in_volume_space(state.volume, *scene.labels.meshes[layer.label].read()[:3]) for layer in layers]
    meshes = {layer.label: mesh[:3] for layer, mesh in zip(layers, placed)}
    written = write_labelled(path, meshes, [layer.color for layer in layers], placed[0][3], one_file)
    state.error = None
    state.message = f"saved {len(layers)} label surface(s): {', '.join(p.name for p, _, _ in written)}"
