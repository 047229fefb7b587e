"""One exception base: every exception class the package defines derives from isoscope.IsoscopeError,
and keeps the built-in base its callers catch (issue 23's point 6)."""
from __future__ import annotations

import importlib
import inspect
import pkgutil

import isoscope
from isoscope.volumes import VolumeError


def _package_modules():
    for info in pkgutil.walk_packages(isoscope.__path__, prefix="isoscope."):
        if info.name.endswith("__main__"):
            continue  # running it is the command
        yield importlib.import_module(info.name)


def test_every_exception_the_package_defines_derives_from_isoscope_error():
    defined = {cls for module in _package_modules() for _, cls in inspect.getmembers(module, inspect.isclass)
               if issubclass(cls, BaseException) and cls.__module__.startswith("isoscope.")}
    assert len(defined) >= 9, sorted(c.__qualname__ for c in defined)
    strays = sorted(f"{c.__module__}.{c.__qualname__}" for c in defined if not issubclass(c, isoscope.IsoscopeError))
    assert not strays, strays


def test_callers_catching_the_builtin_bases_still_catch_them():
    from isoscope.big.cluster import ClusterError
    from isoscope.gpu.context import GLUnavailable
    from isoscope.gpu.limits import GPULimitError
    from isoscope.labels import TooManyLabels
    for cls, builtin in ((VolumeError, ValueError), (GPULimitError, ValueError), (TooManyLabels, ValueError),
                         (ClusterError, RuntimeError), (GLUnavailable, RuntimeError)):
        assert issubclass(cls, builtin) and issubclass(cls, isoscope.IsoscopeError), cls
