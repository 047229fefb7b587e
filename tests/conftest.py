"""Shared fixtures: one real EGL (llvmpipe) context for the session, and small fields."""
from __future__ import annotations

import os
import signal
import subprocess

import numpy as np
import pytest

GL_FIXTURES = {"gl_ctx", "gpu_mesh", "x_display"}  # a test that uses one needs a GL context (or a display)


def restore_default_interrupt() -> None:
    """A suite started in the background (`pytest &` in a shell without job control, nohup, CI runners) has
    SIGINT ignored, and every process it starts inherits that: a command the tests interrupt with SIGINT
    runs on (the hostile tests waited out their two-minute stops), and in-process tests get no
    KeyboardInterrupt.  Python's own handler, back in this process (each xdist worker imports this file),
    is what the processes it starts get too: their SIGINT acts as a user's Ctrl-C does."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


restore_default_interrupt()


def pytest_configure(config):
    config.addinivalue_line("markers", "gl: needs OpenGL 4.3 (EGL, or Xvfb for the window); `pytest -m 'not gl'` "
                                       "runs the rest where there is none")
    if not hasattr(config, "workerinput"):   # the controller (or a one-process run), before any worker starts
        write_bytecode_for_the_suite()
        compile_the_cpu_kernels_once()


def write_bytecode_for_the_suite():
    """Where Python is told not to write bytecode (PYTHONDONTWRITEBYTECODE, as on these machines), every
    interpreter the suite starts (the workers, and the ~200 commands the tests run as a user would) compiled
    isoscope's modules from source again and rewrote the tests' asserts: about 0.17 CPU s a command and 3 s a
    worker. For the suite's processes Python writes its bytecode as it does by default (the __pycache__
    folders, which git ignores), so each module is compiled once. (A PYTHONPYCACHEPREFIX would keep them
    out of the tree, but Python then ignores the __pycache__ that pip wrote for every installed package
    and compiles all of numpy, scipy, numba... again into it: 20 s more on a fresh checkout.) A prefix the
    user set is kept; what the code does is unchanged."""
    import sys
    if not os.environ.get("PYTHONDONTWRITEBYTECODE") or os.environ.get("PYTHONPYCACHEPREFIX"):
        return
    del os.environ["PYTHONDONTWRITEBYTECODE"]   # the workers and the commands, which start after this
    sys.dont_write_bytecode = False               # this process, from here on


def compile_the_cpu_kernels_once():
    """numba compiles the CPU extractor's kernels (isoscope.cpu) at their first call and caches them on disk. On a
    fresh checkout, or after a kernel's source changed, each worker and each command a test starts that gets
    there before the cache is written compiles them itself (30 CPU seconds here), several at once. Here they
    are compiled once before the workers start; a stamp beside numba's cache, named by the sources, skips this
    while they are unchanged."""
    import hashlib
    import importlib.metadata
    import importlib.util
    import sys
    from pathlib import Path
    folder = Path(importlib.util.find_spec("isoscope.cpu").origin).parent
    digest = hashlib.sha1(f"{sys.version_info[:2]} {importlib.metadata.version('numba')}".encode())
    for source in (*sorted(folder.glob("*.py")), Path(__file__)):   # the kernels, and the calls below
        digest.update(source.read_bytes())
    cache = Path(os.environ.get("NUMBA_CACHE_DIR") or folder / "__pycache__")   # where numba writes (cache=True)
    stamp = cache / f"tests-compiled-{digest.hexdigest()[:16]}"
    if stamp.exists():
        return
    import isoscope
    x, y, z = grid(12)
    ball = (0.6 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)
    read_only = ball.copy()
    read_only.flags.writeable = False   # as a memory-mapped file's: another signature
    for field in (ball, read_only):
        isoscope.marching_cubes(field, 0.0, backend="cpu")
        isoscope.marching_tetrahedra(field, 0.0, backend="cpu")
    for dtype in (np.float64, np.int16, np.uint8):   # the kernels read the volume in its own dtype, any order
        scan = ((ball + 1.0) * 100.0).astype(dtype)
        for volume in (scan, np.asfortranarray(scan)):
            isoscope.marching_cubes(volume, 100.0, backend="cpu")
    isoscope.marching_cubes(np.asfortranarray(ball), 0.0, backend="cpu")
    extractor = isoscope.Extractor(ball, backend="cpu")
    for level in (0.0, 0.1):   # a new level measures the words' ranges first
        extractor.extract(level)
    extractor.release()
    try:
        for old in cache.glob("tests-compiled-*"):
            old.unlink()
        stamp.touch()
    except OSError:   # no stamp: this runs again next time, and finds the kernels cached
        pass


def pytest_collection_modifyitems(items):
    """Mark `gl` every test that takes a GL fixture (directly or through another) or a backend "gpu"
    parameter; the others that reach GL (a command that renders, a GPU call) carry the mark themselves."""
    for item in items:
        callspec = getattr(item, "callspec", None)
        on_gpu = callspec is not None and any(isinstance(value, str) and value == "gpu"
                                                  for value in callspec.params.values())
        if on_gpu or GL_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.gl)


@pytest.fixture(scope="session")
def gl_ctx():
    from isoscope.gpu.context import current_or_standalone
    return current_or_standalone()


def grid(n, lo=-1.0, hi=1.0):
    axis = np.linspace(lo, hi, n, dtype=np.float64)
    return np.meshgrid(axis, axis, axis, indexing="ij")


@pytest.fixture
def sphere_sdf():
    """64^3 signed distance to a sphere of radius 0.6 in [-1, 1]^3 (negative inside): (field, radius, voxel)."""
    x, y, z = grid(64)
    return (np.sqrt(x * x + y * y + z * z) - 0.6).astype(np.float32), 0.6, 2.0 / 63


@pytest.fixture
def gpu_mesh(gl_ctx):
    """extract(volume, level, **Extractor options) -> the GPU mesh as numpy arrays."""
    from isoscope.gpu.cubes import Extractor

    def extract(volume, level, **kwargs):
        with Extractor(volume, ctx=gl_ctx, **kwargs) as ex:
            ex.extract(level)
            return ex.read_mesh()
    return extract


def _end_with_the_parent():
    """In the child before exec: SIGTERM it when the process that started it dies (a worker that crashed
    never tears its fixtures down, and an Xvfb left behind spins a little CPU for good)."""
    import ctypes
    import signal
    PR_SET_PDEATHSIG = 1
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


FIRST_TEST_DISPLAY = 90
"""Test X servers take displays from :90 up: never :0, which a desktop (or a program with no DISPLAY, as
Xlib's default) would reach; a no-GL test must not find another worker's Xvfb there."""


@pytest.fixture(scope="module")
def x_display():
    """A private Xvfb server on the first free display from :90 (it says on -displayfd when it is ready)."""
    import random
    start = FIRST_TEST_DISPLAY + random.randrange(200)   # workers starting together try different numbers
    for number in range(start, start + 400):
        read_end, write_end = os.pipe()
        server = subprocess.Popen(["Xvfb", f":{number}", "-displayfd", str(write_end), "-screen", "0", "1024x768x24",
                                   "-nolisten", "tcp", "-noreset"], pass_fds=(write_end,), stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL, preexec_fn=_end_with_the_parent)
        os.close(write_end)
        with os.fdopen(read_end) as ready:
            said = ready.readline().strip()
        if said:
            break
        server.wait(timeout=30)   # that display is taken: the next one
    else:
        pytest.fail("Xvfb did not start on any display from :90")
    yield f":{said}"
    server.terminate()
    server.wait(timeout=30)
