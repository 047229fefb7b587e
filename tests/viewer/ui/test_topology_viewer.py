"""The trilinear topology in the viewer: chosen through ViewerState (the panel's Mesh section, --topology on
render and movie, scenes), drawn, saved and measured as the API makes it, on a context with compute shaders
(its meshes made by the CPU's extractor there too) and back."""
from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from support.command import assert_one_line_error, isoscope_here
from support.trilinear_cases import closed_noise

import isoscope
from isoscope.cpu.measure import measure_surface
from isoscope.options import MeshOptionsError
from isoscope.viewer.gfx.cpu_surface import CpuSurface
from isoscope.viewer.gfx.saving import save_mesh
from isoscope.viewer.model.measure import Measurements
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes import open_volume


@pytest.fixture
def noise_on_show(gl_ctx, tmp_path):
    """A headless viewer showing closed noise at level 0, and the field."""
    field = closed_noise(4, 12)
    np.save(tmp_path / "noise.npy", field)
    viewer = HeadlessViewer((320, 240), ctx=gl_ctx)
    try:
        viewer.show_levels(open_volume(str(tmp_path / "noise.npy")), [0.0])
        yield viewer, field
    finally:
        viewer.release()


def drawn(viewer):
    """The mesh the scene draws, after the frame in which it follows the state."""
    viewer.update()
    return viewer.scene.surface.shown.read_mesh()


def test_the_topology_is_drawn_saved_and_measured_as_the_api_makes_it(noise_on_show, tmp_path):
    viewer, field = noise_on_show
    state = viewer.state
    montani = drawn(viewer)
    first_kind = type(viewer.scene.surface)
    assert state.set_topology("trilinear")
    ours = drawn(viewer)
    expected = isoscope.api.outward_marching_cubes(field, 0.0, topology="trilinear", backend="numpy")
    for a, b in zip(ours, expected):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(ours[1], montani[1])
    assert isinstance(viewer.scene.surface, CpuSurface)   # the viewer makes these meshes on the CPU (surface.py)
    save_mesh(viewer.scene, tmp_path / "saved.ply")
    saved = trimesh.load(tmp_path / "saved.ply", process=False)
    np.testing.assert_array_equal(saved.faces, expected[1])
    # Measure (the panel's section) measures the mesh of the topology on show: the field's own counts.
    measurements = Measurements()
    measurements.request(state, inline=True)
    measurements.poll()
    (record,) = measurements.records
    mesh = measure_surface(*expected[:2])
    assert (record.components, record.euler, record.genus) == (mesh.components, mesh.euler, mesh.genus)
    # And back: today's mesh, on the surface the context first had.
    assert state.set_topology("montani")
    np.testing.assert_array_equal(drawn(viewer)[1], montani[1])
    assert type(viewer.scene.surface) is first_kind
    with pytest.raises(MeshOptionsError, match="topology"):
        state.set_topology("mc33")
    state.set_cells("tetrahedra")
    with pytest.raises(MeshOptionsError, match="not with tetrahedra"):
        state.set_topology("trilinear")
    assert state.mesh_options.topology == "montani"


@pytest.mark.gl   # render draws through OpenGL
def test_render_and_scenes_take_the_topology(tmp_path):
    np.save(tmp_path / "noise.npy", closed_noise(4, 12))
    pictures = {}
    for topology in ("montani", "trilinear"):
        out = tmp_path / f"{topology}.png"
        done = isoscope_here("render", tmp_path / "noise.npy", "--iso", "0", "--topology", topology, "--out", out,
                             "--size", "200x160", "--save-scene", tmp_path / f"{topology}.json")
        assert done.returncode == 0, done.stderr
        pictures[topology] = out.read_bytes()
        scene = json.loads((tmp_path / f"{topology}.json").read_text())
        assert scene["mesh"]["topology"] == topology
    assert pictures["montani"] != pictures["trilinear"]
    from PIL import Image
    ours = isoscope.render(closed_noise(4, 12), 0.0, size=(200, 160), topology="trilinear")
    command = np.asarray(Image.open(tmp_path / "trilinear.png").convert("RGBA"))
    assert np.array_equal(ours, command)   # Python's door draws the command's picture
    again = tmp_path / "again.png"
    done = isoscope_here("render", "--scene", tmp_path / "trilinear.json", "--out", again)
    assert done.returncode == 0, done.stderr
    from PIL import Image
    a = np.asarray(Image.open(again).convert("RGB"), np.int16)
    b = np.asarray(Image.open(tmp_path / "trilinear.png").convert("RGB"), np.int16)
    assert a.shape == b.shape and np.abs(a - b).max() <= 2
    # The scene holds the topology: a flag beside it would be ignored, so it is refused, as --tetrahedra is.
    assert_one_line_error(isoscope_here("render", tmp_path / "trilinear.json", "--topology", "montani", "--out",
                                        tmp_path / "x.png"), "a scene holds the view; --topology")


@pytest.mark.gl
def test_a_scene_with_an_unknown_topology_is_one_line(tmp_path):
    np.save(tmp_path / "noise.npy", closed_noise(4, 12))
    done = isoscope_here("render", tmp_path / "noise.npy", "--iso", "0", "--out", tmp_path / "x.png", "--size",
                         "100x80", "--save-scene", tmp_path / "good.json")
    assert done.returncode == 0, done.stderr
    scene = json.loads((tmp_path / "good.json").read_text())
    scene["mesh"]["topology"] = "mc33"
    (tmp_path / "bad.json").write_text(json.dumps(scene))
    done = isoscope_here("render", "--scene", tmp_path / "bad.json", "--out", tmp_path / "x.png")
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1 and "topology" in done.stderr


@pytest.mark.gl
def test_a_movie_draws_the_topology_as_render_does(tmp_path):
    np.save(tmp_path / "noise.npy", closed_noise(4, 12))
    size = ("--size", "160x120", "--iso", "0", "--topology", "trilinear")
    done = isoscope_here("movie", tmp_path / "noise.npy", *size, "--turntable", "2", "--out", f"{tmp_path / 'turn'}/")
    assert done.returncode == 0, done.stderr
    for topology in ("trilinear", "montani"):
        options = [*size[:-1], topology]
        assert isoscope_here("render", tmp_path / "noise.npy", *options, "--out", tmp_path / f"{topology}.png"
                             ).returncode == 0
    from PIL import Image
    frame = np.asarray(Image.open(tmp_path / "turn" / "frame_0000.png"))
    assert np.array_equal(frame, np.asarray(Image.open(tmp_path / "trilinear.png")))
    assert not np.array_equal(frame, np.asarray(Image.open(tmp_path / "montani.png")))
