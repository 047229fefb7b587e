#!/usr/bin/env python3
"""Benchmark `isoscope.label_surfaces` against zmesh's multi-label marching cubes.

Both mesh every non-zero label of an integer volume as its own closed surface with
vertices at grid-edge midpoints, so their vertex and triangle counts should agree
label by label; the table says whether they do.  Timed, as medians of --repeats:

- ours gpu / ours numpy: `label_surfaces(labels, backend=...)`, from the array to the
  dict of numpy meshes (finding the labels and their boxes included; a warm-up call
  first, so the GL context and shader compilation are not counted);
- zmesh: `Mesher((1, 1, 1)).mesh(labels)` then `mesher.get(label, normals=False)` for
  every label (zmesh's default output; no simplification).

Last column: the largest |enclosed volume / (voxel count x voxel volume) - 1| over the labels.

With --toggle, a second table: the viewer's side (HeadlessViewer at --frame-size, a label map shown as
`isoscope VOLUME --labels` shows it), as medians of --repeats: `show` (extract every label, upload, first
frame: also what a toggle cost if it made the meshes again), `frame` (nothing changed), `toggle` (one
label hidden or shown again: the meshes are kept, only the draw list changes; its own work, then with
the frame that shows it: on a software rasteriser such as llvmpipe the frame is nearly all), `fade`
(a label's opacity to 0.5 and back: the OIT pass), and how many extractions the toggles made (0: none).
Then the toggle as the window shows it (no multisampling on a software renderer, as the window opens
there; each toggle's first frame): with its full surfaces, and with the window's coarse twins of a big
label map on a software renderer (label_scene.py; the full ones are back once the labels rest).

Volumes: `blobs` (16 ellipsoids of 8-30 voxels radius in 256^3 uint32, seeded, later
ones overwriting earlier ones where they overlap, so many pairs share a boundary)
and `mni-tissue` (grey and white matter of the MNI ICBM152 2009a template, labels 1
and 2 where that tissue's probability is at least 50% and above the other's: a real,
folded two-label segmentation; needs nilearn, see benchmarks/README.md).
Markdown on stdout, progress on stderr.
"""
from __future__ import annotations

import argparse
import importlib.metadata
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import isoscope  # noqa: E402

from volumes import MissingVolume, real_volume_path  # noqa: E402


def blobs(n: int = 256, count: int = 16, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    labels = np.zeros((n, n, n), np.uint32)
    axes = np.ogrid[:n, :n, :n]
    for label in range(1, count + 1):
        radii = rng.uniform(8, 30, 3) * n / 256
        centre = rng.uniform(radii.max() + 2, n - radii.max() - 2, 3)
        inside = sum(((axes[a] - centre[a]) / radii[a]) ** 2 for a in range(3)) <= 1
        labels[inside] = label
    return labels


def mni_tissue() -> np.ndarray:
    import nibabel
    grey_path = real_volume_path("mni-gm")
    white_path = grey_path.with_name(grey_path.name.replace("_gm_", "_wm_"))
    grey, white = (np.asarray(nibabel.load(p).dataobj) for p in (grey_path, white_path))
    labels = np.zeros(grey.shape, np.uint8)
    labels[(grey >= 128) & (grey >= white)] = 1
    labels[(white >= 128) & (white > grey)] = 2
    return labels


def ours(labels, backend):
    surfaces = isoscope.label_surfaces(labels, backend=backend)
    return {label: (v, f) for label, (v, f, _) in surfaces.items()}


def zmesh_run(labels):
    import zmesh
    mesher = zmesh.Mesher((1, 1, 1))
    mesher.mesh(labels)
    meshes = {}
    for label in mesher.ids():
        mesh = mesher.get(label, normals=False)
        meshes[int(label)] = (mesh.vertices, mesh.faces)
    return meshes


def volume_error(meshes, labels) -> float:
    """Largest |enclosed volume / voxel count - 1| over the labels (divergence theorem)."""
    voxels = np.bincount(labels.ravel().astype(np.int64))
    worst = 0.0
    for label, (verts, faces) in meshes.items():
        a, b, c = (np.asarray(verts, np.float64)[np.asarray(faces)[:, k]] for k in range(3))
        enclosed = abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6)
        worst = max(worst, abs(enclosed / voxels[label] - 1))
    return worst


def median_ms(run, labels, repeats):
    result, samples = None, []
    for _ in range(repeats):
        start = time.perf_counter()
        result = run(labels)
        samples.append((time.perf_counter() - start) * 1000)
    return statistics.median(samples), result


def toggle_row(name: str, labels: np.ndarray, size: tuple[int, int], repeats: int) -> str:
    """One row of the --toggle table (see the module docstring)."""
    from isoscope.viewer.ui.headless import HeadlessViewer
    from isoscope.volumes.volume import finish_volume
    volume = finish_volume(labels, spacing=(1.0, 1.0, 1.0), name=name, source=name, gradient_direction="descent",
                           default_level=None)
    viewer = HeadlessViewer(size)
    try:
        viewer.show(volume)
        state = viewer.state

        def show():
            state.show_labels()
            viewer.render()
        show_ms = median_ms(lambda _: show(), None, repeats)[0]
        extractions = viewer.scene.labels.extractions
        frame_ms = median_ms(lambda _: viewer.render(), None, repeats)[0]
        first = state.labels.layers[0].label
        flips = iter(range(10 ** 6))

        def toggle():
            state.labels.set_visible(first, next(flips) % 2 == 1)
            viewer.render()

        def fade():
            state.labels.set_opacity(first, 0.5 if next(flips) % 2 else 1.0)
            viewer.render()
        def toggle_work():   # the toggle's own work: the state, the GPU side's step and the draw list
            state.labels.set_visible(first, next(flips) % 2 == 1)
            viewer.scene.update(0.0, wait=True)
            viewer.scene.drawn()
        work_ms = median_ms(lambda _: toggle_work(), None, 2 * repeats + 1)[0]
        toggle_ms = median_ms(lambda _: toggle(), None, 2 * repeats + 1)[0]
        fade_ms = median_ms(lambda _: fade(), None, 2 * repeats + 1)[0]
        made = viewer.scene.labels.extractions - extractions
        _, vertices, triangles = viewer.scene.stats.label_counts()
        return (f"| {name} {'x'.join(map(str, labels.shape))} | {len(state.labels.layers)} | {triangles:,} | "
                f"{show_ms:.0f} | {frame_ms:.0f} | {work_ms:.2f} | {toggle_ms:.0f} | {fade_ms:.0f} | {made} |")
    finally:
        viewer.release()


def window_toggle_ms(labels: np.ndarray, size: tuple[int, int], repeats: int, previews: bool) -> float:
    """A toggle's first frame as the window draws it: GpuScene(previews) into a single-sampled target."""
    from isoscope.gpu.context import DRAWING_GL, current_or_standalone
    from isoscope.viewer.gfx.renderer import OffscreenTarget, SceneRenderer
    from isoscope.viewer.gfx.scene import GpuScene
    from isoscope.viewer.model.camera import OrbitCamera
    from isoscope.viewer.model.state import ViewerState
    from isoscope.volumes.inputs import as_volume
    ctx = current_or_standalone(DRAWING_GL)
    state = ViewerState()
    scene = GpuScene(ctx, state, previews=previews)
    renderer, target = SceneRenderer(ctx), OffscreenTarget(ctx, size, samples=0)
    try:
        scene.show(as_volume(labels))
        state.show_labels()
        scene.update(0.0)
        camera = OrbitCamera()
        camera.fit(*state.bounds())
        first = state.labels.layers[0].label
        samples = []
        for i in range(2 * repeats + 1):
            start = time.perf_counter()
            state.labels.set_visible(first, i % 2 == 1)
            scene.update(1 / 60)
            target.use()
            renderer.draw_scene(scene, camera, target.viewport)
            ctx.finish()
            samples.append((time.perf_counter() - start) * 1000)
            scene.update(1.0)   # the labels rest: the full surfaces again
        return statistics.median(samples)
    finally:
        scene.release()
        renderer.release()
        target.release()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volumes", default="blobs,mni-tissue", help="comma-separated: blobs, mni-tissue")
    parser.add_argument("--size", type=int, default=256, help="edge of the blobs volume (default 256)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--toggle", action="store_true",
                        help="also time showing, hiding and fading a label in the viewer (HeadlessViewer)")
    parser.add_argument("--only-toggle", action="store_true", help="the --toggle table alone")
    parser.add_argument("--frame-size", default="800x600", help="the viewer's picture, WxH (default 800x600)")
    args = parser.parse_args()
    if args.only_toggle or args.toggle:
        size = tuple(int(v) for v in args.frame_size.split("x"))
        print(f"### A label map in the viewer, {size[0]}x{size[1]} (median ms of {args.repeats})\n")
        print("| volume | labels | triangles | show (= re-extract) | frame | toggle, no frame | toggle + frame | "
              "fade + frame | extractions by toggles | window: toggle + frame, full | window: with coarse twins |"
              "\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for name in args.volumes.split(","):
            try:
                labels = blobs(args.size) if name == "blobs" else mni_tissue()
            except MissingVolume as exc:
                print(f"skipped {name}: {exc}", file=sys.stderr)
                continue
            window = [window_toggle_ms(labels, size, args.repeats, previews) for previews in (False, True)]
            print(toggle_row(name, labels, size, args.repeats) + f" {window[0]:.0f} | {window[1]:.0f} |", flush=True)
        print()
        if args.only_toggle:
            return 0
    runners = {"ours gpu": lambda labels: ours(labels, "gpu"), "ours numpy": lambda labels: ours(labels, "cpu")}
    try:
        zmesh_version = importlib.metadata.version("zmesh")
        runners["zmesh"] = zmesh_run
    except importlib.metadata.PackageNotFoundError:
        zmesh_version = "not installed (pip install zmesh)"
    ours(np.pad(np.ones((2, 2, 2), np.uint8), 1), "gpu")  # warm-up: context and shaders
    print(f"### label_surfaces vs zmesh {zmesh_version} (median ms of {args.repeats})\n")
    print("| volume | labels | vertices | triangles | " + " | ".join(runners) + " | counts vs zmesh, per label "
          "| worst volume error, ours / zmesh |")
    print("|---|---:|---:|---:|" + "---:|" * len(runners) + "---|---|")
    for name in args.volumes.split(","):
        try:
            labels = blobs(args.size) if name == "blobs" else mni_tissue()
        except MissingVolume as exc:
            print(f"skipped {name}: {exc}", file=sys.stderr)
            continue
        title = f"{name} {'x'.join(map(str, labels.shape))} {labels.dtype}"
        print(f"running {title}", file=sys.stderr, flush=True)
        times, meshes = {}, {}
        for runner, run in runners.items():
            times[runner], meshes[runner] = median_ms(run, labels, args.repeats)
        counts = {runner: {k: (len(v), len(f)) for k, (v, f) in m.items()} for runner, m in meshes.items()}
        mine = counts["ours gpu"]
        assert counts["ours numpy"] == mine, "the GPU and numpy meshes differ"
        same, errors = "no zmesh", f"{volume_error(meshes['ours gpu'], labels):.2%} / -"
        if "zmesh" in counts:
            errors = f"{volume_error(meshes['ours gpu'], labels):.2%} / {volume_error(meshes['zmesh'], labels):.2%}"
            theirs = counts["zmesh"]
            vertices = all(theirs.get(k, (0, 0))[0] == v for k, (v, _) in mine.items()) and theirs.keys() == mine.keys()
            extra = sum(t for _, t in mine.values()) - sum(t for _, t in theirs.values())
            same = f"vertices {'equal' if vertices else 'differ'}; triangles ours - zmesh: {extra:+,}"
        print(f"| {title} | {len(mine)} | {sum(v for v, _ in mine.values()):,} | "
              f"{sum(t for _, t in mine.values()):,} | " + " | ".join(f"{times[r]:.0f}" for r in runners)
              + f" | {same} | {errors} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
