"""Smoke test of benchmarks/bench_series.py: it plays a small series in the real window (the tests' Xvfb)
and prints its lines (a benchmark nobody runs rots unnoticed)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_series.py"


@pytest.mark.gl
@pytest.mark.parametrize("kind", ["npy", "nii"])
def test_series_benchmark_plays_and_prints_its_lines(kind, x_display):
    env = dict(os.environ, DISPLAY=x_display)
    done = subprocess.run([sys.executable, str(SCRIPT), "--volume", "sphere", "--resolution", "32", "--times", "3",
                           "--points", "4", "--format", kind, "--size", "320x240", "--level", "0"],
                          capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "time points shown" in done.stdout and "frames drawn" in done.stdout
