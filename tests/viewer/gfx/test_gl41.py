"""The viewer, `isoscope render` and the API on an OpenGL 4.1 core context (macOS's; no compute shaders), and
with no GL at all.

Mesa's MESA_GL_VERSION_OVERRIDE=4.1 imitates a Mac: the driver offers a 4.1 core context and no more, so
the meshes come from the CPU extractor and are drawn from a VBO (viewer/gfx/cpu_surface.py).  A 4.1 run is a
subprocess with the override in its environment (Mesa reads it when the process makes its first context);
the 4.3 picture it is held to is drawn by the same command in this process (the tests' own context is 4.3).
The render modes, the torus and `--version` run on 4.1 in one process, one command after another; the
viewer and its window on 4.1 in processes of their own.  "No GL" is an EGL vendor list that names nothing
and no DISPLAY: export and `--version` run in one such process, render (its one line on the process's
stderr) in another.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from support.command import NO_GL, isoscope_batch, isoscope_here

REPO = Path(__file__).resolve().parents[3]
GL41 = {"MESA_GL_VERSION_OVERRIDE": "4.1", "MESA_GLSL_VERSION_OVERRIDE": "410"}
SIZE = "320x240"
CLOSE = 8              # a channel this near counts as the same pixel
SAME_SHARE = 0.99      # of the pixels, at least, the same on 4.1 as on 4.3


def environment(gl41: bool = False, no_gl: bool = False, env_drop_display: bool = False) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MESA_GL")}
    if env_drop_display:
        env.pop("DISPLAY", None)
    if gl41:
        env.update(GL41)
    if no_gl:
        env.update(NO_GL)
        env.pop("DISPLAY", None)
    return env


def isoscope(*args, **env_options) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "isoscope", *map(str, args)], capture_output=True, text=True,
                          env=environment(**env_options), cwd=REPO, timeout=300)


def pixels(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB")).astype(int)


def render_43(tmp_path, name, *args) -> np.ndarray:
    """`isoscope render ARGS` on 4.3 (in this process, on its context): the image."""
    out = tmp_path / f"{name}-43.png"
    result = isoscope_here("render", *args, "--size", SIZE, "--out", out)
    assert result.returncode == 0, result.stderr
    return pixels(out)


MODES = {   # name: `isoscope render` arguments that take a path of their own on 4.1
    "levels": ["metaballs", "--iso", "0.3", "--iso", "0.6", "--opacity", "0.35,1"],   # translucency (OIT)
    "slices": ["bucky", "--slice", "z=32", "--slice", "x=20", "--clip", "y=30"],       # isocurves, clip cap, inset
    "colour": ["gyroid", "--color-by", "gradient", "--wireframe"],
    "panel": ["sphere", "--panel", "--tetrahedra", "--smooth", "2"],
    "sharp": ["box", "--sharp", "30"],
    "labels": ["{folder}/labels.npy", "--labels"],
}

@pytest.fixture(scope="module")
def on41(tmp_path_factory):
    """Every scene of MODES, the torus and `--version` run on 4.1 by one process, one command after another
    (support.command.isoscope_batch): the folder of the images (NAME-41.png) and each command's result."""
    folder = tmp_path_factory.mktemp("on41")
    labels = np.zeros((24, 24, 24), np.uint8)
    labels[4:12, 4:20, 4:20], labels[14:20, 6:18, 8:16] = 1, 2
    np.save(folder / "labels.npy", labels)
    jobs = {name: ["render", *(arg.format(folder=folder) for arg in args), "--size", SIZE,
                   "--out", str(folder / f"{name}-41.png")] for name, args in {**MODES, "torus": ["torus"]}.items()}
    jobs["version"] = ["--version"]
    results = isoscope_batch(*jobs.values(), env_drop=[k for k in os.environ if k.startswith("MESA_GL")],
                             env_add=GL41)
    return folder, dict(zip(jobs, results))


def same_share(a, b) -> float:
    return float((np.abs(a - b).max(axis=2) <= CLOSE).mean())


@pytest.mark.gl
def test_render_on_41_draws_the_surface_as_on_43(on41, tmp_path):
    folder, results = on41
    assert results["torus"].returncode == 0, results["torus"].stderr
    on41, on43 = pixels(folder / "torus-41.png"), render_43(tmp_path, "torus", "torus")
    background = on41[2, 2]
    surface = np.abs(on41 - background).max(axis=2) > 30
    assert 0.05 < surface.mean() < 0.6                     # the surface covers part of the image...
    assert surface[100:140, 100:220].mean() > 0.3          # ...in its middle, where the torus is
    assert same_share(on41, on43) >= SAME_SHARE


@pytest.mark.gl
@pytest.mark.parametrize("name", MODES)   # labels: a label map's surfaces in their colours
def test_render_modes_on_41_match_43(on41, tmp_path, name):
    folder, results = on41
    assert results[name].returncode == 0, results[name].stderr
    on43 = render_43(tmp_path, name, *(arg.format(folder=folder) for arg in MODES[name]))
    assert same_share(pixels(folder / f"{name}-41.png"), on43) >= SAME_SHARE, name


SCRIPT = textwrap.dedent("""
    import numpy as np
    import isoscope
    from isoscope.api import outward_marching_cubes
    from isoscope.gpu.context import current_or_standalone, DRAWING_GL, gl_available
    from isoscope.viewer.gfx.cpu_surface import CpuSurface
    from isoscope.viewer.ui.headless import HeadlessViewer
    from isoscope.volumes import open_volume

    ctx = current_or_standalone(DRAWING_GL)
    assert ctx.version_code == 410, ctx.version_code
    assert not gl_available()          # backend="auto" picks the CPU
    volume = open_volume("sphere", resolution=32)
    verts, faces, _, _ = outward_marching_cubes(volume.data, 0.0, spacing=volume.spacing, gradient_direction="ascent")
    assert len(faces) > 0

    viewer = HeadlessViewer((160, 120))
    viewer.show(volume, 0.0)
    state, scene = viewer.state, viewer.scene
    assert isinstance(scene.surface, CpuSurface)
    assert "OpenGL 4.1, CPU extractor" in state.gl_renderer, state.gl_renderer
    assert scene.stats.n_triangles == len(faces)
    read = scene.surface.shown.read_mesh()
    assert np.array_equal(read[1], faces) and np.allclose(read[0], verts, atol=1e-5)
    before = scene.stats.n_triangles
    state.levels.set_value(0.3)        # the slider: re-extracted on the CPU in the next frame
    viewer.render(panel=True)
    assert scene.stats.n_triangles != before and scene.surface.shown.level == 0.3
    state.levels.add(-0.2)             # a second level: the first keeps its copy
    viewer.update()
    assert scene.stats.level_stats(0)[0] > 0 and scene.stats.level_stats(1)[0] > 0
    viewer.release()

    # Sharp features through the scene (the window's path): made at once with wait, on the worker without.
    viewer = HeadlessViewer((320, 240))
    box = open_volume("box")
    viewer.state.set_sharp(30)
    viewer.show(box)
    viewer.update()                        # the frame that follows the mesh options
    scene = viewer.scene
    expected = outward_marching_cubes(box.data, box.default_level, spacing=box.spacing,
                                      gradient_direction=box.gradient_direction, sharp_features=30, backend="cpu")
    got = scene.surface.shown.read_mesh()
    assert np.array_equal(got[1], expected[1]) and np.allclose(got[0], expected[0], atol=1e-5)
    from PIL import Image
    Image.fromarray(viewer.render()).save(OUT)
    level = viewer.state.iso
    viewer.state.levels.set_value(level + 0.05)
    scene.update(0.0, wait=False)          # the slider at rest in the window: the step goes to the worker
    assert scene.surface.sharp_pending and scene.surface.shown_sharp
    scene.surface.settle()
    assert not scene.surface.sharp_pending and scene.stats.n_triangles > 0
    viewer.release()
    print("ok")
""")


@pytest.mark.gl
def test_viewer_on_41_extracts_on_the_cpu_and_follows_the_slider(tmp_path):
    out = tmp_path / "scene-sharp-41.png"
    result = subprocess.run([sys.executable, "-c", f"OUT = {str(out)!r}\n" + SCRIPT], capture_output=True,
                            text=True, env=environment(gl41=True), cwd=REPO, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "ok"
    # The scene's sharp mesh on 4.1 (crisp normals) looks as `render --sharp` draws it on 4.3.
    assert same_share(pixels(out), render_43(tmp_path, "sharp", "box", "--sharp", "30")) >= SAME_SHARE


@pytest.mark.gl
def test_version_says_the_gl_version_and_the_extractor(on41):
    on41 = on41[1]["version"]
    assert on41.returncode == 0 and "OpenGL 4.1" in on41.stdout and "CPU extractor" in on41.stdout, on41.stdout
    on43 = isoscope_here("--version")
    assert on43.returncode == 0 and "GPU extractor" in on43.stdout, on43.stdout


def test_with_no_gl_export_works_and_render_says_it_needs_opengl(tmp_path):
    out = tmp_path / "torus.ply"
    exported, version = isoscope_batch(["export", "torus", "--out", out], ["--version"],
                                       env_drop=[k for k in os.environ if k.startswith("MESA_GL")] + ["DISPLAY"],
                                       env_add=NO_GL)
    assert exported.returncode == 0, exported.stderr
    assert out.stat().st_size > 0
    rendered = isoscope("render", "torus", "--out", tmp_path / "t.png", no_gl=True)
    assert rendered.returncode == 1
    lines = rendered.stderr.strip().splitlines()
    assert len(lines) == 1 and "needs OpenGL 4.1" in lines[0], rendered.stderr
    assert not (tmp_path / "t.png").exists()
    assert version.returncode == 0 and "no OpenGL" in version.stdout and "CPU extractor" in version.stdout
    window = isoscope("torus", "--frames", "2", no_gl=True)   # the window's refusal points at what works here
    lines = window.stderr.strip().splitlines()
    assert window.returncode == 1 and len(lines) == 1, window.stderr
    assert "isoscope export" in lines[0] and "isoscope render" not in lines[0], lines[0]
    from isoscope.gpu.context import gl_available
    if gl_available():   # GL headless here, but no display: render works, so the window points at it
        no_display = isoscope("torus", "--frames", "2", env_drop_display=True)
        assert no_display.returncode == 1 and "isoscope render" in no_display.stderr, no_display.stderr


@pytest.mark.skipif(shutil.which("Xvfb") is None, reason="Xvfb is not installed (CI installs it)")
def test_window_on_41_opens_re_extracts_and_drags(x_display, tmp_path):
    from support.x_window import run_spawned
    run_spawned(drive_window_on_41, x_display, tmp_path, fresh=True)   # Mesa reads the override once


def drive_window_on_41(x_display, tmp_path):
    """In the spawned process: the override set before its first context, a real window under Xvfb."""
    os.environ.update(GL41, DISPLAY=x_display)
    from support.x_window import Pointer, camera_pose, frames_until, press_key

    from isoscope.viewer.gfx.cpu_surface import CpuSurface
    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow
    from isoscope.volumes import open_volume

    window = ViewerWindow(open_volume("sphere", resolution=32), size=(640, 400), screenshot_dir=tmp_path,
                          recent=RecentFiles(None))
    try:
        state, scene = window.state, window.scene
        for _ in range(3):
            assert window.draw_frame()
        assert window.ctx.version_code == 410 and isinstance(scene.surface, CpuSurface)
        assert state.error is None, state.error
        assert "OpenGL 4.1, CPU extractor" in state.gl_renderer
        assert scene.stats.n_triangles > 0

        low, high = state.value_range
        iso, triangles = state.iso, scene.stats.n_triangles
        press_key(window, "equal", shift=True)   # '+': up 10% of the range, re-extracted on the CPU
        assert frames_until(window, lambda: state.iso == pytest.approx(iso + 0.1 * (high - low)))
        assert scene.surface.shown.level == pytest.approx(state.iso) and scene.stats.n_triangles != triangles

        pointer = Pointer(window)
        (left, top), (right, bottom) = window.panel.iso_slider_box
        iso = state.iso
        pointer.drag(window, (left + 0.25 * (right - left), (top + bottom) / 2),
                     (left + 0.75 * (right - left), (top + bottom) / 2))
        assert frames_until(window, lambda: scene.surface.shown.level == pytest.approx(state.iso))
        assert state.iso != pytest.approx(iso), "the slider did not move"
        pose = camera_pose(window.camera)
        pointer.drag(window, (480, 200), (540, 220))   # in the 3-D view: the camera orbits
        assert camera_pose(window.camera) != pytest.approx(pose)

        press_key(window, "s")
        assert frames_until(window, lambda: window.last_screenshot is not None)
        shot = np.asarray(Image.open(window.last_screenshot).convert("RGB")).astype(int)
        background = np.round(np.array(state.style.background) * 255)
        assert (np.abs(shot[100:300, 380:600] - background).max(axis=2) > 30).mean() > 0.05   # the surface

        # An expr: volume typed in the panel: sampled with numpy (the window's 4.1 context has no compute).
        state.opening.open("expr:x^2 + y^2 + z^2 - 0.3; res=24")
        assert frames_until(window, lambda: state.volume.name.startswith("x^2"))
        assert state.error is None, state.error
        assert any("sampled with numpy" in note for note in state.volume.notes), state.volume.notes
        assert scene.stats.n_triangles > 0
    finally:
        window.close()


@pytest.mark.gl
def test_cpu_surface_tetrahedra_are_the_numpy_tetrahedra(gl_ctx):
    """The 4.1 viewer's tetrahedra (the compiled kernels where numba is installed) are the numpy spec's mesh."""
    from isoscope.cpu.tetra import marching_tetrahedra_reference
    from isoscope.options import MeshOptions
    from isoscope.viewer.gfx.cpu_surface import CpuSurface
    from isoscope.volumes.inputs import as_volume
    x, y, z = np.mgrid[-1:1:21j, -1:1:17j, -1:1:13j]
    field = (0.8 - np.sqrt(x * x + 1.3 * y * y + z * z)).astype(np.float32)
    surface = CpuSurface(gl_ctx, as_volume(field, spacing=(1.0, 2.0, 0.5)), "descent")
    try:
        surface.extract(0.2, MeshOptions(cells="tetrahedra"), wait=True)
        verts, faces, normals, _ = surface.shown.read_mesh()
    finally:
        surface.release()
    ref_verts, ref_faces, ref_normals, _ = marching_tetrahedra_reference(field, 0.2, (1.0, 2.0, 0.5))
    assert len(faces) > 500
    assert np.array_equal(faces, ref_faces)
    assert np.allclose(verts, ref_verts, atol=1e-5)
    assert np.allclose(normals, ref_normals, atol=1e-5)
