"""The public functions' Examples sections run as doctests (issue 23, point 8), so CI checks what they show.

They use small fields and backend="cpu": no GL context, a second or two in all.
"""
from __future__ import annotations

import doctest
import importlib

import pytest

# The modules whose docstrings carry the public functions' examples: marching_cubes, marching_tetrahedra and
# smooth_mesh (api), find_contours (core.contours), label_surfaces (labels); and core.units' length units.
MODULES = ["isoscope.api", "isoscope.core.contours", "isoscope.labels", "isoscope.surface", "isoscope.core.units"]


@pytest.mark.parametrize("name", MODULES)
def test_examples_run(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE, report=False)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples in {name} failed (run with -s)"


@pytest.mark.parametrize("name", ["marching_cubes", "marching_tetrahedra", "smooth_mesh", "find_contours",
                                  "label_surfaces", "isosurface"])
def test_public_functions_have_numpydoc_sections(name):
    import isoscope
    doc = getattr(isoscope, name).__doc__
    for section in ("Parameters", "Returns", "Notes", "References", "Examples"):
        assert f"\n    {section}\n    {'-' * len(section)}\n" in doc, f"{name} has no {section} section"


@pytest.mark.gl
@pytest.mark.parametrize("name", ["isoscope.gpu.cubes", "isoscope.gpu.pool", "isoscope.viewer.scripting"])
def test_gpu_examples_run(name, gl_ctx):
    """The Extractor's and release_gpu_memory's examples, on the session's GL context."""
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE, report=False)
    assert result.attempted > 0 and result.failed == 0, f"{result.failed} of {result.attempted} failed (run -s)"


def test_the_extractor_class_has_numpydoc_sections():
    import isoscope
    doc = isoscope.Extractor.__doc__
    for section in ("Parameters", "Attributes", "Raises", "Notes", "Examples"):
        assert f"\n    {section}\n    {'-' * len(section)}\n" in doc, f"Extractor has no {section} section"
