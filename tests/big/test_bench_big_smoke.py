"""benchmarks/bench_big.py runs end to end at a tiny size (its numbers are not checked, its table is)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_big.py"


@pytest.mark.gl
def test_bench_big_runs_at_48_cubed(tmp_path):
    result = subprocess.run([sys.executable, str(SCRIPT), "--size", "48", "--period", "24", "--chunk", "20",
                             "--dir", str(tmp_path), "--modes", "chunked"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    row = next(line for line in result.stdout.splitlines() if line.startswith("| chunked |"))
    assert "failed" not in row and int(row.split("|")[6].replace(",", "")) > 1000  # triangles
    assert (tmp_path / "gyroid48.zarr").is_dir() and (tmp_path / "chunked.ply").stat().st_size > 0
