"""The compiled (numba) marching cubes against the numpy reference: the same mesh, bit for bit.

The GPU equals the reference in tests/gpu, so these make the three backends one mesh.  Every
volume here goes through the one float32 kernel signature (integers are converted first), so the
JIT compiles each kernel once (and its cache on disk makes later runs start at once)."""
from __future__ import annotations

import numpy as np
import pytest

from isoscope.cpu.compiled import CompiledCubes, marching_cubes_compiled
from isoscope.cpu.cubes import marching_cubes_reference
from isoscope.cpu.extractor import CpuExtractor
from isoscope.volumes.builtins import open_builtin

RNG = np.random.default_rng(20261202)


def assert_identical(got, want):
    """Faces equal, vertices in the same order; positions, normals and values to the bit."""
    for name, a, b in zip(("verts", "faces", "normals", "values"), got, want):
        assert a.dtype == b.dtype and a.shape == b.shape, name
        np.testing.assert_array_equal(a, b, err_msg=name)


def _grid(shape, lo=-1.0, hi=1.0):
    axes = [np.linspace(lo, hi, n) for n in shape]
    return np.meshgrid(*axes, indexing="ij")


def _sphere(shape=(48, 40, 56)):
    x, y, z = _grid(shape)
    return (np.sqrt(x * x + y * y + z * z) - 0.6).astype(np.float32)


def _gyroid(shape=(50, 50, 50)):
    x, y, z = _grid(shape, 0, 4 * np.pi)
    return (np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x)).astype(np.float32)


FIELDS = {
    "sphere": lambda: (_sphere(), 0.0),
    "gyroid": lambda: (_gyroid(), 0.3),
    "noise": lambda: (RNG.normal(size=(40, 33, 70)).astype(np.float32), 0.05),
    "ties": lambda: (RNG.integers(-2, 3, size=(19, 23, 40)).astype(np.float32), 0.0),
    "ambiguous": lambda: (open_builtin("ambiguous").data.astype(np.float32), 0.0),
    "odd": lambda: (RNG.normal(size=(17, 63, 5)).astype(np.float32), 0.1),
}


@pytest.mark.parametrize("direction", ["descent", "ascent"])
@pytest.mark.parametrize("name", sorted(FIELDS))
def test_every_field_gives_the_reference_mesh(name, direction):
    volume, level = FIELDS[name]()
    spacing = (0.5, 2.0, 1.25)
    descent = direction == "descent"
    want = marching_cubes_reference(volume, level, spacing, descent)
    assert len(want[1]) > 0
    assert_identical(marching_cubes_compiled(volume, level, spacing, descent), want)


@pytest.mark.parametrize("shape", [(2, 2, 2), (2, 31, 32), (3, 2, 65), (6, 4, 97), (17, 5, 33), (9, 17, 64),
                                   (120, 120, 2)])
def test_any_grid_size(shape):
    volume = RNG.normal(size=shape).astype(np.float32)
    assert_identical(marching_cubes_compiled(volume, 0.05), marching_cubes_reference(volume, 0.05))


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.float64])
def test_integer_and_wide_inputs(dtype):
    """Integers (scans) at levels that tie with samples and between them; float64 rounds to float32 first."""
    volume = RNG.integers(0, 200, size=(30, 21, 45)).astype(dtype)
    for level in (100, 100.5):
        with CpuExtractor(volume) as ex:
            ex.extract(level)
            assert_identical(ex.read_mesh(), marching_cubes_reference(volume.astype(np.float32), level))


@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_iso_changes_skip_words_yet_keep_the_mesh(direction):
    """After the first level the words' ranges are measured and words the level misses are not read:
    every later level (a sample value itself among them) still gives the reference mesh."""
    volume = _gyroid((40, 70, 90))
    volume[5:9, 3:40, 10:80] = 0.25  # a plateau: whole words equal to a level
    descent = direction == "descent"
    cubes = CompiledCubes(volume, (1.0, 1.0, 1.0), descent)
    for level in (0.0, 0.25, -0.7, 0.25, 1.2, 0.0):
        assert_identical(cubes.extract(level), marching_cubes_reference(volume, level, (1, 1, 1), descent))
    assert cubes._lows is not None


@pytest.mark.parametrize("runs", [1, 2, 3, 7, 200])
def test_any_split_of_the_planes_between_threads(runs):
    """Pass 4 hands runs of planes to the threads, each run starting with a plane of gradients of its own:
    one run, several, one a plane and more runs than planes give the same mesh, an empty run included."""
    volume = _gyroid((23, 40, 70))
    volume[14:] = RNG.normal(size=(9, 40, 70)).astype(np.float32)  # uneven work from plane to plane
    cubes = CompiledCubes(volume, (0.5, 2.0, 1.25), True)
    cubes.runs = runs
    for level in (0.3, -0.2):
        assert_identical(cubes.extract(level), marching_cubes_reference(volume, level, (0.5, 2.0, 1.25), True))


def test_a_level_that_cuts_nothing():
    volume = _sphere((20, 20, 20))
    mesh = marching_cubes_compiled(volume, float(volume.max()) + 1.0)
    assert_identical(mesh, marching_cubes_reference(volume, float(volume.max()) + 1.0))
    verts, faces, normals, values = mesh
    assert verts.shape == (0, 3) and faces.shape == (0, 3) and normals.shape == (0, 3) and values.shape == (0,)
    assert faces.dtype == np.int32


def test_another_case_table():
    """The labels' table (loops folded for volume) through the same kernels."""
    from isoscope.core.case_table import label_table
    indicator = (RNG.integers(0, 4, size=(20, 30, 40)) == 1).astype(np.float32)
    table = label_table()
    assert_identical(marching_cubes_compiled(indicator, 0.5, table=table),
                     marching_cubes_reference(indicator, 0.5, table=table))


@pytest.mark.parametrize("direction", ["descent", "ascent"])
@pytest.mark.parametrize("name", ["sphere", "noise", "ties", "ambiguous", "odd"])
def test_tetrahedra_give_the_reference_mesh(name, direction):
    from isoscope.cpu.compiled import marching_tetrahedra_compiled
    from isoscope.cpu.tetra import marching_tetrahedra_reference
    volume, level = FIELDS[name]()
    spacing = (0.5, 2.0, 1.25)
    descent = direction == "descent"
    want = marching_tetrahedra_reference(volume, level, spacing, descent)
    assert len(want[1]) > 0
    assert_identical(marching_tetrahedra_compiled(volume, level, spacing, descent), want)


def test_flat_fields_give_the_reference_normals_on_every_kind_of_edge():
    """A checkerboard has no central-difference gradient inside: normals point along the edges, the
    tetrahedra's diagonals included (a float64 unit vector in numpy, rounded to float32)."""
    from isoscope.cpu.compiled import marching_tetrahedra_compiled
    from isoscope.cpu.tetra import marching_tetrahedra_reference
    volume = (np.indices((6, 7, 8)).sum(axis=0) % 2).astype(np.float32)
    for spacing in ((0.5, 2.0, 1.25), (0.3, 0.7, 1.9)):
        want = marching_tetrahedra_reference(volume, 0.5, spacing, False)
        assert (np.abs(want[2]).sum(axis=1) > 1.01).any()  # some normals along a diagonal
        assert_identical(marching_tetrahedra_compiled(volume, 0.5, spacing, False), want)
        assert_identical(marching_cubes_compiled(volume, 0.5, spacing), marching_cubes_reference(volume, 0.5, spacing))


def test_threads_extracting_at_once_get_their_meshes(tmp_path):
    """Two threads extract at once (the viewer's preview and its worker), also under numba's workqueue
    threading layer, which aborts the process on concurrent parallel launches unless they take turns."""
    import os
    import subprocess
    import sys
    script = tmp_path / "threads.py"
    script.write_text(
        "import threading, numpy as np\n"
        "from isoscope.cpu.compiled import marching_cubes_compiled\n"
        "from isoscope.cpu.cubes import marching_cubes_reference\n"
        "v = np.random.default_rng(1).normal(size=(40, 50, 60)).astype(np.float32)\n"
        "want = {lvl: marching_cubes_reference(v, lvl)[1] for lvl in (0.0, 0.5)}\n"
        "bad = []\n"
        "def run(lvl):\n"
        "    for _ in range(15):\n"
        "        bad.append(not np.array_equal(marching_cubes_compiled(v, lvl)[1], want[lvl]))\n"
        "threads = [threading.Thread(target=run, args=(lvl,)) for lvl in (0.0, 0.5)]\n"
        "[t.start() for t in threads]; [t.join() for t in threads]\n"
        "import numba; print(numba.threading_layer(), len(bad), any(bad))\n")
    env = dict(os.environ, NUMBA_THREADING_LAYER="workqueue", NUMBA_NUM_THREADS="2")
    out = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["workqueue", "30", "False"]
