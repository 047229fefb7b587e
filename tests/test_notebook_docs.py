"""docs/python.ipynb (issue 25): the notebook shows view, render, widget and isosurface on a real scan (the MNI
T1 template nilearn ships), its stored pictures are of that scan, and it runs from top to bottom in a fresh
kernel (its `view` cell keeps its level instead of opening a window: ISOSCOPE_NOTEBOOK_TEST), giving what its
text says: a brain-sized closed surface and scikit-image's vertices and values."""
from __future__ import annotations

import base64
import importlib.util
import io
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

nbformat = pytest.importorskip("nbformat")

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "python.ipynb"


def code_cells(notebook):
    return [cell for cell in notebook.cells if cell.cell_type == "code"]


def cell_calling(notebook, call: str):
    return next(cell for cell in code_cells(notebook) if call in cell.source)


def pictures(cell) -> list[np.ndarray]:
    return [np.asarray(Image.open(io.BytesIO(base64.b64decode(output.data["image/png"]))).convert("RGB"))
            for output in cell.outputs if "image/png" in output.get("data", {})]


def text(cell) -> str:
    return "".join(output.get("text", "") for output in cell.outputs if output.output_type == "stream")


def assert_a_lit_surface(picture: np.ndarray) -> None:
    """A surface fills a fair part of the middle, and none of the corners (the background)."""
    background = picture[2, 2].astype(int)
    lit = np.abs(picture.astype(int) - background).sum(axis=2) > 60
    h, w = lit.shape
    assert 0.05 < lit[h // 4: 3 * h // 4, w // 4: 3 * w // 4].mean() < 0.95
    assert not lit[:h // 10, :w // 10].any() and not lit[-h // 10:, -w // 10:].any()


def test_the_notebook_shows_the_four_doors_with_their_pictures():
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(notebook)
    source = "\n".join(cell.source for cell in code_cells(notebook))
    for call in ("isoscope.view(", "isoscope.render(", "isoscope.widget(", "isoscope.isosurface(",
                 "isoscope.marching_cubes("):
        assert call in source, call
    assert "mni_icbm152_t1" in source   # a real scan, not a made-up field
    rendered = pictures(cell_calling(notebook, "image = isoscope.render("))
    assert len(rendered) == 1 and rendered[0].shape == (480, 640, 3)
    assert_a_lit_surface(rendered[0])
    assert_a_lit_surface(pictures(cell_calling(notebook, "get_frame()"))[0])


@pytest.mark.gl
def test_the_notebook_runs_in_a_fresh_kernel(monkeypatch, tmp_path):
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    if importlib.util.find_spec("nilearn") is None:
        pytest.skip("the notebook's scan ships in nilearn's wheel: pip install -e .[bench]")
    monkeypatch.setenv("ISOSCOPE_NOTEBOOK_TEST", "1")   # the kernel inherits it: no window
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    for cell in code_cells(notebook):
        cell.outputs = []
    nbclient.NotebookClient(notebook, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()  # raises on an error

    assert_a_lit_surface(pictures(cell_calling(notebook, "image = isoscope.render("))[0])
    two = pictures(cell_calling(notebook, "opacities="))[0]
    assert_a_lit_surface(two)
    frame = pictures(cell_calling(notebook, "get_frame()"))[0]
    assert frame.shape == (360, 480, 3)
    assert_a_lit_surface(frame)

    said = text(cell_calling(notebook, "isoscope.isosurface("))
    assert "watertight: True" in said
    litres = float(re.search(r"volume ([0-9.]+) litres", said).group(1))
    assert 1.0 < litres < 2.5          # a brain (the template's, skull stripped, with its ventricles)
    drop_in = text(cell_calling(notebook, "isoscope.marching_cubes("))
    assert "every vertex is one of scikit-image's: True" in drop_in and "with its value: True" in drop_in
