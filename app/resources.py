"""Find the package's data files (GLSL sources, sample volumes) from a checkout or a wheel.

In a checkout they sit at the top level (`shaders/`, `volumes/`); pyproject.toml
installs them into the wheel as the data packages `isoscope._shaders` and `isoscope._volumes`.
"""
from __future__ import annotations

import re
from pathlib import Path

from .errors import InputError

_PACKAGE_DIR = Path(__file__).resolve().parent
_CHECKOUT_ROOT = _PACKAGE_DIR.parent
_INCLUDE = re.compile(r'^\s*#include\s+"([\w./-]+)"\s*$', re.MULTILINE)


def _data_dir(checkout_name: str) -> Path:
    local = _CHECKOUT_ROOT / checkout_name
    if local.is_dir():
        return local
    # Installed: isoscope/_shaders, isoscope/_volumes.  Not through importlib.resources: these folders
    # have no __init__.py, so it hands back a MultiplexedPath whose str() is no path at all.
    return _PACKAGE_DIR / f"_{checkout_name}"


def shaders_dir() -> Path:
    """The folder of the GLSL files: shaders/ in a checkout, isoscope/_shaders when installed."""
    return _data_dir("shaders")


def volumes_dir() -> Path:
    """The folder of the bundled volumes: volumes/ in a checkout, isoscope/_volumes when installed."""
    return _data_dir("volumes")


def shader_source(name: str, defines: dict[str, object] | None = None) -> str:
    """Read shaders/NAME, expand `#include "file"` lines, and add `#define`s after `#version`.

    GLSL has no include; shared helpers (the case-table layout, sampling) live
    in their own .glsl files and are pasted in here, once each.
    """
    seen: set[str] = set()

    def expand(file_name: str) -> str:
        """`file_name`'s text with its includes expanded, each file pasted in once (a second include of it adds
        nothing)."""
        if file_name in seen:
            return ""
        seen.add(file_name)
        text = (shaders_dir() / file_name).read_text()
        return _INCLUDE.sub(lambda m: expand(m.group(1)), text)

    source = expand(name)
    if defines:
        lines = source.split("\n", 1)
        if not lines[0].startswith("#version"):
            raise InputError(f"{name}: first line must be #version")
        extra = "".join(f"#define {k} {v}\n" for k, v in defines.items())
        source = lines[0] + "\n" + extra + (lines[1] if len(lines) > 1 else "")
    return source
