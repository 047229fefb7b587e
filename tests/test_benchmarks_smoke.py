"""The benchmark script runs end to end on tiny volumes and reports every peer (not a timed test).

PyMCubes is hidden from the run on purpose, so one run checks both paths: a
peer that is there is measured, a peer that is missing is skipped with a note
(in CI only the `test` extra is installed: scikit-image and scipy, no PyMCubes
or VTK).
"""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parent.parent / "benchmarks" / "bench_extract.py"
PEER_COLUMNS = {  # column label -> module whose absence makes the script skip it
    "scikit-image (lewiner)": "skimage",
    "PyMCubes": "mcubes",
    "VTK FlyingEdges3D 2T": "vtkmodules",
    "VTK FlyingEdges3D 1T": "vtkmodules",
}


def importable(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def table_rows(stdout: str, title: str) -> tuple[list[str], list[list[str]]]:
    """The header and body cells of the markdown table under `### title...`."""
    lines = stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"### {title}"))
    table = []
    for line in lines[start + 1:]:
        if line.startswith("|"):
            table.append([cell.strip() for cell in line.strip("|").split("|")])
        elif table:
            break
    return table[0], table[2:]


@pytest.mark.gl
def test_benchmark_script_prints_every_peer(tmp_path):
    hidden = tmp_path / "hidden"
    hidden.mkdir()
    (hidden / "mcubes.py").write_text('raise ImportError("hidden by the smoke test")\n')
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(hidden), env.get("PYTHONPATH")]))
    out_json = tmp_path / "bench.json"

    proc = subprocess.run(
        # --warmup 0: no untimed runs, which would go on for half a second per runner and volume
        [sys.executable, str(SCRIPT), "--sizes", "24", "--repeats", "1", "--warmup", "0", "--json", str(out_json)],
        capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    stdout = proc.stdout

    for title in ("Iso change", "First extraction"):
        header, rows = table_rows(stdout, title)
        assert [row[1] for row in rows] == ["sphere", "gyroid", "noise"]
        for label, module in PEER_COLUMNS.items():
            assert label in header, f"no {label} column in {title}: {header}"
            cells = [row[header.index(label)] for row in rows]
            if module != "mcubes" and importable(module):
                assert all(float(cell) > 0 for cell in cells), (label, cells)
            else:
                assert cells == ["skipped"] * 3, (label, cells)

    assert "PyMCubes skipped: not importable" in stdout
    if not importable("vtkmodules"):
        assert "VTK FlyingEdges3D 2T skipped: not importable" in stdout
    # Every peer that ran found the same surface as ours (triangle counts, vertices on the level).
    assert "- WARNING:" not in stdout, stdout

    report = json.loads(out_json.read_text())
    assert [c["volume"] for c in report["cases"]] == ["sphere", "gyroid", "noise"]
    for case in report["cases"]:
        assert case["ours"]["iso_change"]["triangles"]["a"] > 0
        assert case["peers"]["mcubes"]["skipped"] == "not importable"


@pytest.mark.gl
def test_load_cost_benchmark_measures_every_kind_of_load():
    script = SCRIPT.parent / "bench_loads.py"
    done = subprocess.run([sys.executable, str(script), "--invocations", "65536"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    rows = [line.strip("|").split("|") for line in done.stdout.splitlines() if line.startswith("| ")]
    kinds = [cells[0].strip() for cells in rows[1:]]
    assert kinds == ["SSBO uint", "uniform block uvec4 (small table)", "texelFetch usampler2D r32ui",
                     "imageLoad uimage2D r32ui", "texelFetch sampler3D rgba32f", "imageLoad image3D rgba32f"]
    for cells in rows[1:]:
        assert all(float(cell) > 0 for cell in cells[1:])


@pytest.mark.gl
@pytest.mark.parametrize("flags", [(), ("--gl41",)], ids=["gpu", "gl41"])
def test_viewer_benchmark_drags_and_prints_its_lines(flags, x_display):
    """bench_viewer opens the real window (the tests' Xvfb) and times a drag; it broke once unnoticed."""
    env = dict(os.environ, DISPLAY=x_display)
    done = subprocess.run([sys.executable, str(SCRIPT.parent / "bench_viewer.py"), "--frames", "3", "--volume",
                           "bucky", "--size", "320x240", *flags], capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "frame       median" in done.stdout
    assert ("CPU extractor" if flags else "GPU extractor") in done.stdout


@pytest.mark.gl
def test_viewer_benchmark_makes_its_memory_map_and_reports_rest_and_memory(x_display, tmp_path):
    """--memmap N makes an N^3 uint8 .npy once (a slab at a time) and drags it; the time back to full
    resolution and the peak RSS are reported."""
    env = dict(os.environ, DISPLAY=x_display)
    command = [sys.executable, str(SCRIPT.parent / "bench_viewer.py"), "--frames", "3", "--memmap", "40",
               "--dir", str(tmp_path), "--size", "320x240"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    made = np.load(tmp_path / "smooth_40x40x40.npy", mmap_mode="r")
    assert made.shape == (40, 40, 40) and made.dtype == np.uint8 and made.min() < 100 < made.max()
    assert "smooth_40x40x40.npy 40x40x40" in done.stdout
    assert "after the last move" in done.stdout and "peak RSS" in done.stdout and "uint8" in done.stdout


@pytest.mark.gl
@pytest.mark.parametrize("kind", ["--memmap", "--pyramid"])
def test_viewer_benchmark_past_the_budget_reports_the_bricks(x_display, tmp_path, kind):
    """With a --memory-budget the map (or its OME-Zarr pyramid) is over, the window shows bricks: the bench waits
    for what the room holds and says how many, how long, and the frames meanwhile."""
    env = dict(os.environ, DISPLAY=x_display)
    command = [sys.executable, str(SCRIPT.parent / "bench_viewer.py"), "--frames", "3", kind, "80",
               "--dir", str(tmp_path), "--size", "320x240", "--memory-budget", "1M"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    line = [line for line in done.stdout.splitlines() if line.strip().startswith("bricks")]
    assert line and "bricks at full resolution" in line[0] and "frames meanwhile median" in line[0], done.stdout
    assert "peak RSS" in line[0] and "of 80x80x80 at rest" in done.stdout
