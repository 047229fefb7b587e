"""Shared fixtures: one real EGL (llvmpipe) context for the session, and small fields."""
from __future__ import annotations

import os
import subprocess

import numpy as np
import pytest


@pytest.fixture(scope="session")
def gl_ctx():
    from isoscope.gl_context import current_or_standalone
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
    from isoscope.extractor import Extractor

    def extract(volume, level, **kwargs):
        with Extractor(volume, ctx=gl_ctx, **kwargs) as ex:
            ex.extract(level)
            return ex.read_mesh()
    return extract


@pytest.fixture(scope="module")
def x_display():
    """A private Xvfb server; -displayfd makes it pick a free display number and say when it is ready."""
    read_end, write_end = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write_end), "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
                              pass_fds=(write_end,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_end)
    with os.fdopen(read_end) as ready:
        number = ready.readline().strip()
    if not number:
        server.kill()
        pytest.fail("Xvfb did not start")
    yield f":{number}"
    server.terminate()
    server.wait(timeout=30)
