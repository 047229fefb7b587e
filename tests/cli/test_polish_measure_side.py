"""measure gives the object's volume positive: a closed surface enclosing the values below the level of a
volume taken as a density (object above: a file's default) is a signed distance's object, below the level,
and one note line says so.  Checked on the built-in torus (ring R 0.6, tube r 0.25: 2 pi^2 R r^2) and the
sample volumes/torus.nrrd made from it (distance x 1000, 40 samples over [-1, 1], spacing 1 1 2 mm)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from support.command import isoscope_here

from isoscope.cpu.measure import measure_surface

R, TUBE = 0.6, 0.25


def torus_mm3(tube: float, scale=(1.0, 1.0, 1.0)) -> float:
    return 2 * math.pi ** 2 * R * tube ** 2 * math.prod(scale)


def measured(*args):
    result = isoscope_here("measure", *args, "--json")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout), result.stderr


@pytest.mark.parametrize("level", [0.0, 0.1])
def test_the_builtin_torus_measures_its_analytic_volume_below_the_level(level):
    (record,), notes = measured("torus", "--iso", str(level))
    assert record["inside"] == "below" and record["open_edges"] == 0 and notes == ""
    assert record["volume_ml"] * 1000 == pytest.approx(torus_mm3(TUBE + level), rel=0.01)
    assert record["largest_component_ml"] == record["volume_ml"]


def test_the_other_side_given_is_turned_and_said_in_one_note_line():
    (record,), notes = measured("torus", "--iso", "0", "--inside", "above")
    assert record["inside"] == "below"
    assert record["volume_ml"] * 1000 == pytest.approx(torus_mm3(TUBE), rel=0.01)
    (line,) = notes.strip().splitlines()
    assert line.startswith("note: level 0: the object is below the level") and "--inside below" in line


def test_the_sample_nrrd_torus_is_positive_where_it_was_minus_10_9_ml():
    scale = (39 / 2, 39 / 2, 39.0)   # mm per unit of the built-in's [-1, 1]: 39 samples' steps of 1, 1, 2 mm
    (record,), notes = measured("volumes/torus.nrrd", "--iso", "0.5")
    assert record["volume_ml"] > 0 and record["inside"] == "below" and "--inside below" in notes
    assert record["volume_ml"] * 1000 == pytest.approx(torus_mm3(TUBE + 0.0005, scale), rel=0.02)
    text = isoscope_here("measure", "volumes/torus.nrrd", "--iso", "0.5")
    assert "volume 10.9" in text.stdout and "-" not in text.stdout.split("volume")[1].split("mL")[0]
    assert len(text.stderr.strip().splitlines()) == 1
    # --closed: the box capped at the border, the object above the level is the box less the torus.
    (capped,), notes = measured("volumes/torus.nrrd", "--iso", "0.5", "--closed")
    assert capped["inside"] == "above" and notes == "" and capped["volume_ml"] > 100


def test_a_cavity_is_subtracted_and_an_open_surface_is_not_turned():
    (record,), notes = measured("torus", "--iso", "0.5", "--inside", "above")   # the tube leaves the box
    assert record["open_edges"] > 0 and record["inside"] == "above" and notes == ""
    # A shell: a ball of radius 0.8 with a ball of 0.4 hollowed out (object above 0: between them).
    axis = np.linspace(-1, 1, 65)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    distance = np.sqrt(x * x + y * y + z * z)
    from isoscope.api import outward_marching_cubes
    shell = np.minimum(0.8 - distance, distance - 0.4).astype(np.float32)
    verts, faces, _, _ = outward_marching_cubes(shell, 0.0, spacing=(2 / 64,) * 3)
    m = measure_surface(verts, faces)
    expected = 4 / 3 * math.pi * (0.8 ** 3 - 0.4 ** 3)
    assert m.components == 2 and m.volume == pytest.approx(expected, rel=0.01) and not m.turned
    assert m.smallest_component_volume == pytest.approx(-4 / 3 * math.pi * 0.4 ** 3, rel=0.02)
    # Wound the other way (the object taken as the values below 0): measured turned, the same shell.
    turned = measure_surface(verts, faces[:, ::-1])
    assert turned.turned and turned.volume == pytest.approx(m.volume)
    assert turned.largest_component_volume == pytest.approx(m.largest_component_volume)
