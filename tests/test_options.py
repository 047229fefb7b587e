"""One mesh-options spec (isoscope.options.MeshOptions): each rule has one wording, and the Python API,
the command line and the viewer refuse a combination with that same wording (issue 23, point 3)."""
from __future__ import annotations

import numpy as np
import pytest
from support.command import isoscope_here

import isoscope
from isoscope.options import MeshOptions, MeshOptionsError

RULES = [
    (MeshOptions(cells="tetrahedra", sharp=30.0), "method of cubes"),
    (MeshOptions(smooth=2, sharp=30.0), "round off the sharp features"),
    (MeshOptions(smooth=1, masked=True), "a mask keeps cells of the plain mesh"),
    (MeshOptions(sharp=30.0, masked=True), "a mask keeps cells of the plain mesh"),
    (MeshOptions(masked=True, chunked=True), "a mask keeps cells of the plain mesh"),
    (MeshOptions(smooth=3, chunked=True), "plain marching cubes"),
    (MeshOptions(cells="tetrahedra", chunked=True), "plain marching cubes"),
    (MeshOptions(cells="hexahedra"), "unknown cells"),
    (MeshOptions(topology="trilinear", masked=True), "not with tetrahedra, sharp features or a mask"),
    (MeshOptions(topology="trilinear", chunked=True, smooth=2), "plain marching cubes"),
]


@pytest.mark.parametrize("options, words", RULES)
def test_each_rule_refuses_in_its_words(options, words):
    assert words in options.problem()
    with pytest.raises(MeshOptionsError, match=words) as caught:
        options.check()
    assert isinstance(caught.value, ValueError) and isinstance(caught.value, isoscope.IsoscopeError)


@pytest.mark.parametrize("options", [MeshOptions(), MeshOptions(cells="tetrahedra", smooth=5),
                                     MeshOptions(sharp=30.0), MeshOptions(masked=True), MeshOptions(chunked=True),
                                     MeshOptions(topology="trilinear", chunked=True)])
def test_what_goes_together_passes(options):
    assert options.problem() is None and options.check() is options


def test_the_api_the_command_and_the_viewer_say_the_same(sphere_sdf, tmp_path):
    field, _, _ = sphere_sdf
    rule = MeshOptions(smooth=2, sharp=30.0).problem()
    with pytest.raises(ValueError) as caught:
        isoscope.marching_cubes(field, 0.0, smooth=2, sharp_features=30, backend="cpu")
    assert str(caught.value) == rule

    np.save(tmp_path / "f.npy", field)
    run = isoscope_here("export", tmp_path / "f.npy", "--smooth", "2", "--sharp", "30", "--out", tmp_path / "f.stl")
    assert run.returncode == 2 and run.stderr.strip() == f"isoscope: error: {rule}"

    from isoscope.viewer.model.state import ViewerState  # the viewer's model: no GL
    state = ViewerState()
    assert state.set_smooth(2)
    with pytest.raises(MeshOptionsError) as caught:
        state.set_sharp(30)
    assert str(caught.value) == rule
