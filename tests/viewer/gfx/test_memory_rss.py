"""The viewer's process within its memory budget on a software renderer (issue 33: "a small --memory-budget
forces bricks, keeps RSS within it, plus a stated overhead")."""
from __future__ import annotations

import numpy as np
import pytest

from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes.inputs import as_volume


@pytest.fixture(scope="module")
def wrinkled():
    """A ball with a ripple, 96^3 float32: ~60 k triangles at level 0, many of them in front of others."""
    axis = np.linspace(-1, 1, 96, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    return (0.7 - np.sqrt(x * x + y * y + z * z) + 0.05 * np.sin(9 * x) * np.sin(9 * y) * np.sin(9 * z)
            ).astype(np.float32)


@pytest.mark.parametrize("style", ["opaque", "wireframe", "translucent"])
def test_drawing_in_chunks_with_waits_between_gives_the_same_picture(gl_ctx, wrinkled, style):
    """The renderer waits for the GL every SOFTWARE_DRAW_TRIANGLES on llvmpipe (renderer.DrawPacer); a mesh
    drawn in pieces of 997 triangles, each piece from its own first triangle, is the mesh drawn whole."""
    viewer = HeadlessViewer((320, 240), ctx=gl_ctx)
    try:
        viewer.show(as_volume(wrinkled, name="wrinkled"), 0.0)
        if style == "wireframe":
            viewer.state.style.wireframe = True
        if style == "translucent":
            viewer.state.levels.set_opacity(0, 0.5)
        pacer = viewer.renderer.pacer
        pacer.every = 0
        whole = viewer.render()
        triangles = sum(mesh.n_triangles for mesh in viewer.scene.stats.meshes)
        pacer.every = 997
        pieces = viewer.render()
    finally:
        viewer.release()
    assert triangles > 20 * 997
    assert (whole != whole[0, 0]).any(axis=2).mean() > 0.05   # the surface is drawn
    np.testing.assert_array_equal(pieces, whole)


RSS_SCRIPT = r"""
import gc, json, sys
import numpy as np
from isoscope.big.chunked import extract_box
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes import open_volume
from isoscope.volumes.inputs import as_volume


def rss_anon():
    gc.collect()
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) << 10 for line in status if line.startswith("RssAnon:"))


path, budget, size = sys.argv[1], sys.argv[2], (int(sys.argv[3]), int(sys.argv[4]))
rays = sys.argv[5] if len(sys.argv) > 5 else None   # a ray-cast mode, drawn with the surfaces
viewer = HeadlessViewer(size, memory_budget=budget)
# the process before any volume: GL, the window's targets, the GPU programs and numba's CPU kernels loaded
axis = np.linspace(-1, 1, 48, dtype=np.float32)
x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
ball = (100 + 100 * (0.6 - np.sqrt(x * x + y * y + z * z))).astype(np.uint8)
viewer.show(as_volume(ball, name="ball"), 100.0)
if rays:   # the ray caster's program and the opaque scene's targets: no more with a bigger volume
    viewer.state.set_raycast(rays)
    viewer.state.set_with_surfaces(True)
viewer.render()
extract_box(ball, ((0, 0, 0), (47, 47, 47)), 100.0, (1.0, 1.0, 1.0), True, backend="cpu")
before = rss_anon()
viewer.show(open_volume(path, map_files=True), 100.0)
viewer.render()
bricks = viewer.state.bricks
after = rss_anon()
print(json.dumps({"growth": after - before, "before": before, "budget": viewer.state.budget.bytes,
                  "bricks": bricks is not None and bricks.text, "full": bricks is not None and bricks.full_in_view,
                  "step": viewer.state.step, "mesh": sum(m.bytes for m in bricks.meshes.values()) if bricks else 0,
                  "room": bricks.layout.room if bricks else 0,
                  "rays": len(bricks.rays.loaded) if bricks else 0, "slots": bricks.rays.capacity if bricks else 0}))
"""


@pytest.fixture(scope="module")
def wrinkled_map(tmp_path_factory):
    """A 256^3 uint8 .npy (16 MiB) of a ball with a fine ripple: at level 100 a closed surface of ~1 M triangles
    at full resolution; opened memory-mapped, so its samples are the page cache's, not the process's."""
    path = tmp_path_factory.mktemp("rss") / "wrinkled.npy"
    n = 256
    out = np.lib.format.open_memmap(path, mode="w+", dtype=np.uint8, shape=(n, n, n))
    axis = np.linspace(-1, 1, n, dtype=np.float32)
    y, z = axis[None, :, None], axis[None, None, :]
    for start in range(0, n, 32):
        x = axis[start:start + 32, None, None]
        field = 200 * np.exp(-(x * x + y * y + z * z) / 0.4) + 30 * np.sin(14 * x) * np.sin(14 * y) * np.sin(14 * z)
        out[start:start + 32] = np.clip(field + 20, 0, 255).astype(np.uint8)
    out.flush()
    del out
    return path


def rss_growth(path, budget: str, size=(640, 480), rays=None) -> dict:
    """In a fresh process (no other test's memory in the measure): RssAnon after the volume at `path` is shown
    and every brick in view refined, minus before it was opened (GL, numba's kernels, the targets loaded)."""
    import json
    import os
    import subprocess
    import sys
    arguments = [str(path), budget, *map(str, size), *([rays] if rays else [])]
    done = subprocess.run([sys.executable, "-c", RSS_SCRIPT, *arguments], capture_output=True, text=True,
                          timeout=300, env=os.environ.copy())
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.gl
@pytest.mark.parametrize("budget, rays", [("32M", None), ("40M", "mip")])
def test_a_volume_over_a_small_budget_keeps_the_process_within_the_budget_and_the_stated_overhead(
        wrinkled_map, budget, rays):
    """Surfaces alone, and ray cast (MIP) with the surfaces: the rays' bricks in their atlas (llvmpipe's RAM)
    and the surfaces' bricks share the room."""
    from isoscope.core.budget import SOFTWARE_OVERHEAD_BYTES, parse_size
    measured = rss_growth(wrinkled_map, budget, rays=rays)
    assert measured["budget"] == parse_size(budget) and measured["step"] >= 2   # over the budget: bricks
    if rays:
        assert 0 < measured["rays"] == measured["slots"], measured                # the rays' room used
        assert measured["mesh"] > 0.1 * measured["room"], measured                # the surfaces' too
    else:
        assert measured["full"], measured                                         # every brick in view refined
        assert measured["mesh"] > 0.3 * measured["room"], measured                # the room was used
    assert measured["growth"] <= parse_size(budget) + SOFTWARE_OVERHEAD_BYTES, measured
