"""Scenes, as 3D Slicer's scenes and ParaView's state files: what is on show, saved as a small, readable,
versioned JSON and put back on show later (`isoscope scene.json`, `isoscope render scene.json`).

A scene names its volume (the path or spec it was opened from, with the open options), and holds the
levels (value, colour, opacity, visibility; the selected one), the object's side, the mesh modes, labels,
colour by, the camera, the image size, slices, window/centre, colour map, clip, inset, and the look.
Reading checks every field and says in one line what is wrong (another format or version, a value out of
its range); a volume that is no longer there is named with the fix.  No GL here.
"""
from __future__ import annotations

import json
from dataclasses import asdict, fields
from pathlib import Path

import numpy as np

from ...core.opener import UnreadablePath, read_text, shown
from .errors import ViewerError
from .scene_schema import SceneError, _brief, check_scene
from .style import SurfaceStyle

FORMAT = "isoscope-scene"
VERSION = 1
MAX_SCENE_BYTES = 1 << 20   # a scene is a few kilobytes; anything larger is not one


def is_scene_file(spec: str) -> bool:
    """A path ending in .json that exists (the command takes it as a scene where it takes a volume)."""
    return isinstance(spec, str) and spec.lower().endswith(".json") and Path(spec).expanduser().is_file()


def scene_of(state, camera, size) -> dict:
    """The scene on show, as a JSON-ready dict."""
    volume = state.full_volume or state.volume
    if volume is None:
        raise SceneError("no volume on show to save in a scene; open one first")
    source = volume.source
    if Path(source).expanduser().exists():
        source = str(Path(source).expanduser().resolve())
    slices = state.slices
    return {
        "format": FORMAT, "version": VERSION,
        "volume": {"source": source, "open_options": _plain(volume.open_options),
                   "gradient_direction": volume.gradient_direction},
        "levels": [{"value": level.value, "color": None if level.color is None else list(level.color),
                    "opacity": level.opacity, "visible": level.visible} for level in state.levels.items],
        "selected": state.levels.selected,
        "mesh": {"cells": state.mesh_options.cells, "smooth": state.mesh_options.smooth,
                 "sharp": state.mesh_options.sharp, "closed": state.closed,
                 "topology": state.mesh_options.topology},
        "labels": state.labels.saved() if state.labels else False,   # or true (older scenes): the defaults
        "color_by": None if state.color_by is None else {"source": state.color_by.spec,
                                                         "colormap": state.color_by.colormap},
        "camera": {"azimuth": camera.azimuth, "elevation": camera.elevation, "distance": camera.distance,
                   "target": [float(v) for v in camera.target]},
        "size": [int(size[0]), int(size[1])],
        "slices": {"shown": list(slices.shown), "index": list(slices.index), "active": slices.active,
                   "window": slices.window, "centre": slices.centre, "colormap": slices.colormap,
                   "inset": slices.inset,
                   "clip": None if slices.clip is None else {"axis": slices.clip.axis,
                                                             "position": slices.clip.position,
                                                             "hide_above": slices.clip.hide_above}},
        "style": _plain(asdict(state.style)),
        "raycast": state.raycast,
        "with_surfaces": state.with_surfaces,
        "transfer": None if state.transfer is None else [list(point) for point in state.transfer],
    }


def write_scene(path, scene: dict) -> Path:
    """Write `scene` to `path` as indented JSON (no NaN or infinity), whole or not at all; returns the path written."""
    from ...io.atomic import write_atomically
    text = json.dumps(scene, indent=2, allow_nan=False) + "\n"
    return write_atomically(path, lambda out: out.write(text.encode()))


def read_scene(path) -> dict:
    """The scene in the file `path`, its format, version and every field checked (scene_schema), relative
    paths in it taken from the scene's folder; SceneError with one line if not."""
    path = Path(path).expanduser()
    name = shown(path.name)
    try:
        text = read_text(path, "the scene", MAX_SCENE_BYTES)
        scene = json.loads(text, parse_constant=_no_constant)
    except UnreadablePath as exc:
        raise SceneError(str(exc)) from None
    except RecursionError:
        raise SceneError(f"{name} nests its JSON too deeply to be a scene; is it one?") from None
    except ValueError as exc:   # json.JSONDecodeError, and NaN / Infinity (not JSON, though Python writes them)
        raise SceneError(f"{name} is not a scene (not JSON: {shown(str(exc).splitlines()[0])[:120]})") from None
    if not isinstance(scene, dict) or scene.get("format") != FORMAT:
        raise SceneError(f"{name} is JSON but not an isoscope scene (no \"format\": \"{FORMAT}\")")
    version = scene.get("version")
    if isinstance(version, bool) or version != VERSION:
        raise SceneError(f"{name} is a scene of version {_brief(version)}; this isoscope reads version {VERSION}: "
                         "save it again with this version")
    scene = check_scene(scene, name)
    folder = path.resolve().parent
    scene["volume"]["source"] = _from_folder(scene["volume"]["source"], folder)
    if scene.get("color_by"):
        scene["color_by"]["source"] = _from_folder(scene["color_by"]["source"], folder)
    if isinstance(scene.get("labels"), dict) and scene["labels"].get("names"):
        scene["labels"]["names"] = _from_folder(scene["labels"]["names"], folder)
    source = scene["volume"]["source"]
    if _looks_like_file(source) and not _exists(source):
        raise SceneError(f"{name} shows {shown(source)}, which is not there any more; put the file back, or edit "
                         "volume.source in the scene")
    return scene


def _no_constant(word: str):
    raise ValueError(f"{word} is not a JSON number")


def _looks_like_file(source: str) -> bool:
    return not source.lower().startswith("expr:") and ("/" in source or Path(source).suffix != "")


def _from_folder(source: str, folder: Path) -> str:
    """A relative path in a scene, taken from the scene's folder (as a web page's links are) where it names
    something there; an absolute path, a built-in's name or an expr: as it is."""
    if not _looks_like_file(source) or Path(source).expanduser().is_absolute():
        return source
    beside = folder / source
    return str(beside) if _exists(str(beside)) else source


def volume_spec(scene: dict) -> tuple[str, dict]:
    """(spec, open options) of the scene's volume (read_scene checked them: the command's own volume flags),
    for open_volume."""
    volume = scene["volume"]
    options = dict(volume.get("open_options") or {})
    for key in ("dims", "spacing"):
        if key in options:
            options[key] = tuple(options[key])
    return volume["source"], options


def apply_scene(scene: dict, state, camera) -> None:
    """Put the scene's levels, modes, slices, look and camera on the state showing its volume; a value that
    does not fit this volume raises with the one line the panel would give."""
    try:
        direction = scene["volume"].get("gradient_direction")
        if direction is not None:
            state.set_gradient_direction(direction)
        levels = _field(scene, "levels", list)
        if not levels:
            raise SceneError("the scene has no levels")
        items = state.levels
        low, high = items.value_range
        for level in levels:
            if not low <= float(level["value"]) <= high:
                raise SceneError(f"the scene's level {float(level['value']):g} is outside the volume's value range "
                                 f"{low:g} .. {high:g}; the file has changed since, or edit the scene")
        items.set_value(float(levels[0]["value"]))
        for level in levels[1:]:
            items.add(float(level["value"]))
        for i, level in enumerate(levels):
            if level.get("color") is not None:
                items.set_color(i, level["color"])
            items.set_opacity(i, float(level.get("opacity", 1.0)))
            items.set_visible(i, bool(level.get("visible", True)))
        items.select(int(scene.get("selected", 0)))
        mesh = scene.get("mesh") or {}
        state.set_cells(mesh.get("cells", "cubes"))
        state.set_topology(mesh.get("topology", "montani"))
        state.set_smooth(int(mesh.get("smooth", 0)))
        state.set_sharp(mesh.get("sharp"))
        state.closed = bool(mesh.get("closed", False))
        labels = scene.get("labels")
        if labels:
            state.show_labels(names=labels.get("names") if isinstance(labels, dict) else None,
                              force=True)   # shown as labels when it was saved
            state.labels.restore(labels if isinstance(labels, dict) else {})
        color_by = scene.get("color_by")
        if color_by:
            state.set_color_by(color_by["source"], color_by.get("colormap"))
        _apply_slices(scene.get("slices") or {}, state.slices)
        state.set_raycast(scene.get("raycast"))
        state.set_with_surfaces(bool(scene.get("with_surfaces")))
        state.set_transfer(scene.get("transfer"))
        style = scene.get("style") or {}
        known = {f.name for f in fields(SurfaceStyle)}
        for name, value in style.items():
            if name in known:
                setattr(state.style, name, tuple(value) if isinstance(value, list) else value)
        cam = _field(scene, "camera", dict)
        camera.azimuth, camera.elevation = float(cam["azimuth"]), float(cam["elevation"])
        camera.distance = float(cam["distance"])
        camera.target = np.asarray(cam["target"], float).reshape(3)
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        if isinstance(exc, ViewerError):
            raise
        raise SceneError(f"the scene does not fit: {exc}") from None


def apply_opened_scene(state, camera, raise_errors: bool = False) -> None:
    """A scene opened through `state.opening.open` whose volume is now on show: its levels, modes, slices,
    look and camera put on it (model/scene_file.py).  A scene that does not fit this volume leaves the
    volume as opened, with the one line in the status bar (or raised, `raise_errors`)."""
    scene, state.opening.scene_to_apply = state.opening.scene_to_apply, None
    if scene is None:
        return
    from .errors import USER_ERRORS, one_line
    try:
        apply_scene(scene, state, camera)
    except USER_ERRORS as exc:
        if raise_errors:
            raise
        state.error = one_line(exc)


def scene_size(scene: dict) -> tuple[int, int]:
    """The scene's image size (read_scene checked it: each side as --size takes it), else 800x600."""
    width, height = scene.get("size") or [800, 600]
    return int(width), int(height)


def _apply_slices(settings: dict, slices) -> None:
    for axis, (on, index) in enumerate(zip(settings.get("shown", [False] * 3), settings.get("index", [0] * 3))):
        if on:
            slices.show(axis, True, int(index))
        else:
            slices.index[axis] = int(index)
    if "active" in settings:
        slices.active = int(settings["active"])
    if "window" in settings:
        slices.set_window(settings["window"], settings.get("centre"))
    if settings.get("colormap"):
        slices.set_colormap(settings["colormap"])
    slices.inset = bool(settings.get("inset", True))
    clip = settings.get("clip")
    slices.set_clip(None if not clip else int(clip["axis"]), None if not clip else clip["position"],
                    True if not clip else bool(clip.get("hide_above", True)))


def _field(scene: dict, name: str, kind: type):
    value = scene.get(name)
    if not isinstance(value, kind):
        raise SceneError(f"the scene's {name!r} is missing or not a {kind.__name__}")
    return value


def _exists(source: str) -> bool:
    path = Path(source).expanduser()
    return path.exists() or ("*" in source or "?" in source)


def _plain(value):
    """Tuples as lists, numpy numbers as Python ones: what json writes."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
