"""The `isoscope` command: the viewer window, headless renders, mesh export, the list of built-ins.

Bad input ends with one line on stderr naming the problem and the fix, and
exit status 2; no traceback reaches the user.
"""
from __future__ import annotations

import argparse
import errno
import os
import sys

from ..viewer.model.slice_options import add_slice_arguments, apply_slice_arguments
from ..volumes import DEFAULT_VOLUME, VolumeError
from .volume_options import add_volume_arguments, open_volume_from_args

EXIT_BAD_INPUT = 2
EXIT_NO_GL = 1
EXIT_CLUSTER_FAILED = 1  # the machine, not the input: a cluster failed, the disk is full
COMMANDS = ("render", "export", "volumes")

KEYS_HELP = """\
keys in the window:
  =  -      iso value up / down by 1% of the volume's range
  +  _      up / down by 10%
  space     animate the iso value through the range (again to stop)
  w         wireframe overlay          l   lighting on/off
  r         reset the view and panel   s   screenshot to a PNG (path printed and shown)
  Esc       quit
mouse: left drag orbits, right/middle (or shift+left) drag pans, wheel zooms;
  drag the panel by its title bar or an empty spot (it stays in reach; r puts it back).
Drop a volume file on the window to open it.

other commands (each has --help):
  isoscope render VOLUME --out shot.png [--iso V] [--size WxH] [--azimuth A] [--elevation E] [--panel]
                [--transparent] [--iso V2 ...] [--opacity A,B] [--color-by value|gradient|FILE] [--color-by-map NAME]
                [--slice AXIS=INDEX ...] [--clip AXIS=POS[:+|-]] [--window W] [--level L] [--colormap NAME]
                [--tetrahedra] [--smooth N] [--sharp DEG]
  isoscope export VOLUME --out mesh.ply|.obj|.stl|.glb|.off [--iso V [--iso V2 ...]] [--tetrahedra] [--smooth N]
                [--sharp DEG]
  isoscope export SEGMENTATION --labels --out seg.stl      one mesh per label: seg_label<N>.stl
                [--chunk N] [--workers N] [--scheduler ADDRESS]   big volumes, a chunk at a time
  isoscope volumes          list the built-in volumes
"""

VOLUME_HELP = ("a built-in name (isoscope volumes), a file (.npy .npz .nrrd .nii .nii.gz .tif .raw), a DICOM folder, "
               "a Zarr or OME-Zarr folder, "
               "or expr:FORMULA, e.g. 'expr:x^2+y^2+z^2-0.5'")


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line that points at --help.

    A VOLUME path that starts with '-' goes after '--' (`isoscope export --out m.stl -- -scan.npy`);
    options may follow it too (`isoscope export -- -scan.npy --out m.stl`): VOLUME is the one positional,
    so the word right after '--' is it."""

    _given: list[str] = []

    def parse_args(self, args=None, namespace=None):
        self._given = list(sys.argv[1:] if args is None else args)
        return super().parse_args(volume_after_dashes(self._given), namespace)

    def error(self, message: str):
        stray = self._stray_option() if "VOLUME" in message else None
        if stray is not None:
            message += (f"; {stray!r} is not an option: a path that starts with '-' goes after '--', e.g. "
                        f"{self.prog} ... -- {stray}")
        # "isoscope: error:" as every other refusal, whichever subcommand: scripts look for one prefix.
        self.exit(EXIT_BAD_INPUT, f"isoscope: error: {message} (see {self.prog} --help)\n")

    def _stray_option(self) -> str | None:
        """The first argument that looks like an option but is none of this parser's (nor a prefix of one)."""
        for arg in self._given:
            if arg == "--":
                return None
            name = arg.split("=", 1)[0]
            if len(arg) > 1 and arg.startswith("-") and not _is_number(arg) and not any(
                    option.startswith(name) for option in self._option_string_actions):
                return arg
        return None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def volume_after_dashes(args: list[str]) -> list[str]:
    """`A -- VOLUME B` as `A B -- VOLUME`: argparse takes every word after '--' as a positional, and VOLUME is
    the only one, so options given after it would be refused as extra arguments."""
    if "--" not in args:
        return args
    at = args.index("--")
    after = args[at + 1:]
    return args[:at] + after[1:] + ["--", after[0]] if len(after) >= 2 and after[1].startswith("-") else args


def window_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size {text!r} is not WIDTHxHEIGHT, e.g. 800x600") from None
    if not (16 <= width <= 16384 and 16 <= height <= 16384):
        raise argparse.ArgumentTypeError(f"size {text!r} must be between 16x16 and 16384x16384 pixels")
    return width, height


def _add_iso(parser: argparse.ArgumentParser, several: str = "") -> None:
    """--iso V; with `several` (what several levels give) it may be repeated, up to MAX_LEVELS times."""
    parser.add_argument("--iso", type=float, metavar="V", action="append" if several else "store",
                        help="iso value (default: the volume's suggested level, else mid-range)" + several)


def opacities(text: str) -> list[float]:
    """--opacity A[,B,...]: one opacity 0..1 per level, in --iso order."""
    try:
        values = [float(part) for part in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"opacity {text!r} is not numbers, e.g. 0.3 or 0.3,1") from None
    if not all(0.0 <= value <= 1.0 for value in values):
        raise argparse.ArgumentTypeError(f"opacity {text!r} must lie in 0..1 (1 opaque, 0 invisible)")
    return values


def _add_levels_look(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--opacity", type=opacities, action="append", metavar="A[,B..]",
                        help="opacity of each level in --iso order, repeatable or comma-separated, e.g. "
                             "--opacity 0.3,1 (default 1: opaque); translucent shells are drawn "
                             "order-independently (weighted blended OIT)")
    parser.add_argument("--color-by", metavar="value|gradient|FILE",
                        help="colour the surfaces by a colour map of: the level's value, the volume's "
                             "|gradient|, or a second volume FILE of the same shape (e.g. PET or dose); "
                             "a colour bar is drawn at the right")
    parser.add_argument("--color-by-map", metavar="NAME",
                        help="colour map of the cmap library for --color-by (default viridis; e.g. magma, "
                             "turbo, gray)")


def _add_tetrahedra(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--tetrahedra", action="store_true",
                        help="march tetrahedra (6 per cell) instead of cubes: no ambiguous cells, "
                             "about three times the triangles")


def _add_smooth(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--smooth", type=smooth_iterations, default=0, metavar="N",
                        help="N iterations of smoothing, each projected back onto the level set: evens out "
                             "sliver triangles without moving the surface (default 0: none)")


def smooth_iterations(text: str) -> int:
    from ..cpu.smooth import check_iterations  # the API's rule, in the flag's words
    try:
        return check_iterations(int(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--smooth {text!r} must be a whole number of iterations, 0 or more") \
            from None


def feature_angle(text: str) -> float:
    from ..cpu.sharp.features import check_feature_angle
    try:
        return check_feature_angle(float(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--sharp {text} must be a feature angle in degrees between 0 and 180 "
                                         "(exclusive), e.g. 30") from None


def max_labels(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"--max-labels {text!r} must be a whole number of labels, 1 or more")
    return value


def _add_sharp(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--sharp", type=feature_angle, metavar="DEG",
                        help="sharp edges and corners (Extended Marching Cubes) where normals open wider than DEG "
                             "degrees, e.g. 30")


def _add_mesh_modes(parser: argparse.ArgumentParser, labels: str) -> None:
    """The flags that choose what surface is made: cells, smoothing, sharp features, a label map."""
    _add_tetrahedra(parser)
    _add_smooth(parser)
    _add_sharp(parser)
    parser.add_argument("--labels", action="store_true",
                        help=f"VOLUME is a label map (a segmentation): {labels}")


def viewer_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="isoscope",
        description="Live GPU isosurfaces of 3-D scalar fields. With no VOLUME, opens the viewer on "
                    f"the built-in '{DEFAULT_VOLUME}' volume.",
        epilog=KEYS_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("volume", nargs="?", default=DEFAULT_VOLUME, metavar="VOLUME", help=VOLUME_HELP)
    _add_iso(parser)
    parser.add_argument("--size", type=window_size, default=(1280, 800), metavar="WxH",
                        help="window size in screen units (default 1280x800)")
    _add_mesh_modes(parser, labels="each non-zero label's surface in its own colour, listed in the panel")
    parser.add_argument("--screenshot-dir", default=".", metavar="DIR",
                        help="where key s saves PNGs (default: the current directory)")
    parser.add_argument("--screenshot-scale", type=int, default=1, choices=range(1, 9), metavar="N",
                        help="key s saves the scene at N times the window's pixels, 1-8 (default 1: the "
                             "window as shown, panel included; above 1 the scene alone, for print)")
    parser.add_argument("--frames", type=int, metavar="N",
                        help="quit after drawing N frames (scripts, benchmarks, smoke tests)")
    parser.add_argument("--msaa", type=int, choices=(0, 2, 4, 8), metavar="N",
                        help="multisampling, samples per pixel: 0, 2, 4 or 8 (default 4 on a GPU, "
                             "0 on software OpenGL such as llvmpipe, where it costs 3x the frame time)")
    add_slice_arguments(parser)
    add_volume_arguments(parser)
    return parser


def command_parser(command: str) -> argparse.ArgumentParser:
    if command == "volumes":
        return OneLineParser(prog="isoscope volumes", description="List the built-in volumes.")
    if command == "render":
        parser = OneLineParser(
            prog="isoscope render",
            description="Render the viewer's scene to a PNG with no window or display (EGL).")
        parser.add_argument("volume", metavar="VOLUME", help=VOLUME_HELP)
        _add_iso(parser, "; repeat for several surfaces (up to 4)")
        _add_levels_look(parser)
        parser.add_argument("--out", required=True, metavar="PNG", help="the PNG file to write")
        parser.add_argument("--size", type=window_size, default=(800, 600), metavar="WxH",
                            help="image size in pixels (default 800x600)")
        parser.add_argument("--azimuth", type=float, metavar="DEG",
                            help="camera angle around the vertical (z) axis, degrees (default -60)")
        parser.add_argument("--elevation", type=float, metavar="DEG",
                            help="camera angle above the x-y plane, degrees, -89..89 (default 25)")
        parser.add_argument("--panel", action="store_true", help="draw the imgui panel over the scene")
        parser.add_argument("--transparent", action="store_true",
                            help="a transparent background: an RGBA PNG, for slides and figures")
        parser.add_argument("--wireframe", action="store_true", help="draw the triangles' edges over the surface")
        add_slice_arguments(parser)
        _add_mesh_modes(parser, labels="draw each non-zero label's surface in its own colour")
    else:
        parser = OneLineParser(prog="isoscope export",
                               description="Extract the isosurface and write it as a mesh file: binary PLY, OBJ, "
                                           "binary STL, GLB (glTF) or OFF, by the extension of --out.")
        parser.add_argument("volume", metavar="VOLUME", help=VOLUME_HELP)
        _add_iso(parser, "; repeat for several levels (up to 4): one file per level, named "
                         "STEM_iso<V>.EXT after --out (e.g. head_iso0.5.ply)")
        parser.add_argument("--out", required=True, metavar="MESH",
                            help="the file to write: .ply, .obj, .stl, .glb or .off (replaced only once complete)")
        parser.add_argument("--space", choices=("world", "voxel"), default="world",
                            help="world (default): the file's own world coordinates where it defines them "
                                 "(NIfTI: RAS; NRRD and DICOM: LPS, as 3D Slicer saves models), so the mesh "
                                 "overlays the scan; voxel: array index x spacing")
        parser.add_argument("--decimate", type=float, metavar="FRACTION",
                            help="keep about this fraction of the triangles (quadric decimation, 0 < F <= 1); "
                                 "prints how far the result strays from the level set")
        _add_mesh_modes(parser, labels="one closed surface per non-zero label, neighbours sharing their "
                                       "boundary vertices, written to STEM_label<N>.EXT beside --out "
                                       "(e.g. seg.stl -> seg_label1.stl, seg_label2.stl)")
        parser.add_argument("--one-file", action="store_true",
                            help="with --labels: all labels in the one --out file (.ply or .glb), each vertex "
                                 "in its label's colour")
        parser.add_argument("--max-labels", type=max_labels, metavar="N",
                            help="with --labels: refuse a volume of more than N labels (default 255), before "
                                 "writing anything: a scan given --labels by mistake has one per grey value")
        add_big_volume_arguments(parser)
    add_volume_arguments(parser)
    return parser


def _progress(fraction: float, message: str) -> None:
    # Slow loads report progress; overwrite one line on a terminal, stay quiet in logs.  With
    # ISOSCOPE_PROGRESS set (the viewer's background export reads them), one line per report.
    if sys.stderr.isatty():
        end = "\n" if fraction >= 1.0 else ""
        print(f"\r{message} {fraction:4.0%}\033[K", end=end, file=sys.stderr, flush=True)
    elif os.environ.get("ISOSCOPE_PROGRESS"):
        print(f"{message} {fraction:.0%}", file=sys.stderr, flush=True)


def _checked_iso(volume, iso: float | None) -> float | None:
    if iso is None:
        return volume.default_level
    low, high = volume.value_range
    if not low <= iso <= high:
        raise VolumeError(f"--iso {iso:g} is outside {volume.name}'s value range {low:g} .. {high:g}; "
                          "pick a value inside it")
    return iso


def _checked_levels(volume, isos: list[float] | None, opacity_lists=None) -> list[float | None]:
    """The --iso values (one None: the default level), each in range, at most MAX_LEVELS; and
    no more --opacity values than levels."""
    from ..viewer.model.levels import MAX_LEVELS
    isos = isos or [None]
    if len(isos) > MAX_LEVELS:
        raise VolumeError(f"--iso given {len(isos)} times; at most {MAX_LEVELS} surfaces at once")
    given = sum(len(values) for values in opacity_lists or [])
    if given > len(isos):
        raise VolumeError(f"{given} opacities for {len(isos)} levels; give one per --iso, in order")
    return [_checked_iso(volume, iso) for iso in isos]


def level_path(out, level: float) -> str:
    """Where export writes `level` when given several: STEM_iso<V>.EXT beside `out`."""
    from pathlib import Path
    out = Path(out)
    return str(out.with_name(f"{out.stem}_iso{level:g}{out.suffix}"))


def run_viewer(args) -> int:
    # Sample expr: volumes with numpy here: a GPU sampler would make an EGL context current,
    # and GLX then refuses the window's context in this process (X_GLXMakeCurrent BadAccess).
    # Inside the window the panel samples on the GPU, in the window's own context.
    volume = open_volume_from_args(args.volume, args, _progress, backend="cpu")
    iso = _checked_iso(volume, args.iso)
    from ..viewer.ui.window import ViewerWindow, WindowUnavailable
    try:
        window = ViewerWindow(volume, iso, size=args.size, screenshot_dir=args.screenshot_dir, msaa=args.msaa,
                              screenshot_scale=args.screenshot_scale)
    except WindowUnavailable as exc:
        print(f"isoscope: {exc}", file=sys.stderr)
        return EXIT_NO_GL
    try:
        apply_slice_arguments(window.state, args)
        _apply_mesh_arguments(window.state, args)
    except ValueError:
        window.close()
        raise
    window.run(max_frames=args.frames)
    return 0


def _apply_mesh_arguments(state, args) -> None:
    """--labels, --tetrahedra, --smooth, --sharp on the viewer: through ViewerState, as the panel does;
    a refusal raises its one line (MeshOptionsError, a ValueError) and changes nothing."""
    if args.labels:
        state.show_labels()
    if args.tetrahedra:
        state.set_cells("tetrahedra")
    if args.smooth:
        state.set_smooth(args.smooth)
    if args.sharp is not None:
        state.set_sharp(args.sharp)


def _check_label_options(args, *options: str) -> None:
    """--labels draws or writes every label's boundary: refuse the options that have no meaning there."""
    for option in options:
        if getattr(args, option.strip("-").replace("-", "_"), None) not in (None, False):
            raise ValueError(f"{option} does not apply with --labels (each label's surface is its boundary); "
                             f"leave out {option}" if args.labels else f"{option} needs --labels; add --labels")


def _wrote(path, what: str) -> None:
    """Say what was written, on stdout; on stderr where the file written is stdout itself (`--out
    /dev/stdout | viewer`), so the line does not land in the PNG or mesh."""
    try:
        into_stdout = os.path.samefile(path, "/dev/stdout")
    except (OSError, ValueError):
        into_stdout = False
    print(f"wrote {path}{'' if what.startswith(':') else ' '}{what}", file=sys.stderr if into_stdout else sys.stdout)


def run_render(args) -> int:
    from ..gpu.context import current_or_standalone
    from ..viewer.ui.headless import check_render_size
    check_render_size(args.size)  # pixels: before a GL context is made
    check_render_size(args.size, current_or_standalone())  # the driver's limits, before the volume is read
    if args.labels:
        _check_label_options(args, "--iso", "--panel")
        from ..viewer.ui.headless import render_labels_png
        volume = open_volume_from_args(args.volume, args, _progress)
        path = render_labels_png(volume, args.out, size=args.size, azimuth=args.azimuth, elevation=args.elevation,
                                 transparent=args.transparent)
        _wrote(path, f"({args.size[0]}x{args.size[1]})")
        return 0
    from ..viewer.model.colormaps import check_colormap
    if args.color_by_map:
        check_colormap(args.color_by_map)  # an unknown map is refused before any work
    volume = open_volume_from_args(args.volume, args, _progress)
    isos = _checked_levels(volume, args.iso, args.opacity)
    if args.sharp is not None:
        for option in ("--panel", "--tetrahedra", "--smooth", "--labels", "--slice", "--clip", "--color-by"):
            if getattr(args, option.strip("-").replace("-", "_"), None) not in (None, False, 0, []):
                raise ValueError(f"render --sharp draws the one sharp-featured surface; leave out {option}")
        if len(isos) > 1:
            raise ValueError("render --sharp draws one level; give one --iso")
        from ..viewer.ui.headless import render_sharp_png
        path = render_sharp_png(volume, args.out, isos[0], args.sharp, size=args.size, azimuth=args.azimuth,
                                elevation=args.elevation, transparent=args.transparent)
        _wrote(path, f"({args.size[0]}x{args.size[1]})")
        return 0
    from ..viewer.ui.headless import render_png
    path = render_png(volume, args.out, isos, size=args.size, azimuth=args.azimuth,
                      elevation=args.elevation, panel=args.panel, transparent=args.transparent,
                      opacities=[a for values in args.opacity or [] for a in values],
                      color_by=args.color_by, colormap=args.color_by_map,
                      tetrahedra=args.tetrahedra, smooth=args.smooth, wireframe=args.wireframe,
                      prepare=lambda state: apply_slice_arguments(state, args))
    _wrote(path, f"({args.size[0]}x{args.size[1]})")
    return 0


def add_big_volume_arguments(parser) -> None:
    parser.add_argument("--chunk", type=int, metavar="N",
                        help="extract N^3-cell chunks one at a time and stitch them (the same mesh, in memory "
                             "bounded by the chunk); the default for Zarr volumes (128)")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="run the chunks on a local dask cluster of N worker processes (pip install "
                             "'isoscope[big]')")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run the chunks on the dask cluster whose scheduler is at ADDRESS "
                             "(e.g. tcp://10.0.0.5:8786); its workers must reach the volume's path")


def max_workers() -> int:
    """--workers at most: each worker is a process with its own OpenGL context and chunk buffers."""
    return max(4, 4 * (os.cpu_count() or 1))


def _check_workers(args) -> None:
    """--workers within 1..max_workers(), refused before the volume is read."""
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers {args.workers}: give 1 or more worker processes")
    if args.workers is not None and args.workers > max_workers():
        raise ValueError(f"--workers {args.workers} is more worker processes than this machine runs "
                         f"({os.cpu_count()} cores: at most {max_workers()}); give fewer, or --scheduler for a "
                         "cluster of machines")
    if args.workers is not None and args.scheduler is not None:
        raise ValueError("--workers starts a local cluster, --scheduler uses another one; give one of them")


def _extract_for_export(volume, iso, args):
    """The export's mesh: whole, a chunk at a time here, or a chunk per task on a dask cluster."""
    from ..core.lazy_arrays import is_lazy
    from ..options import MeshOptions
    distributed = args.scheduler is not None or args.workers is not None
    chunked = args.chunk is not None or distributed or is_lazy(volume.data)
    problem = MeshOptions(cells="tetrahedra" if args.tetrahedra else "cubes", smooth=args.smooth, sharp=args.sharp,
                          chunked=chunked).problem()
    if problem is not None:
        why = "" if not chunked else ("this export is chunked (--chunk, --workers, --scheduler, or a Zarr or "
                                      "memory-mapped volume): ")
        raise ValueError(why + problem)
    if not chunked:
        from .. import marching_cubes, marching_tetrahedra
        if args.tetrahedra:
            return marching_tetrahedra(volume.checked, iso, spacing=volume.spacing,
                                       gradient_direction=volume.gradient_direction, smooth=args.smooth)
        return marching_cubes(volume.checked, iso, spacing=volume.spacing, gradient_direction=volume.gradient_direction,
                              smooth=args.smooth, sharp_features=args.sharp)
    from ..big.chunked import DEFAULT_CHUNK, as_chunks, marching_cubes_chunked
    from ..validation import as_level
    chunks = as_chunks(DEFAULT_CHUNK if args.chunk is None else args.chunk, volume.data.shape)
    level = as_level(iso, volume.value_range)
    descent = volume.gradient_direction == "descent"
    if distributed:
        from ..big.cluster import marching_cubes_on_cluster
        return marching_cubes_on_cluster(volume.data, level, volume.spacing, descent, chunks,
                                         scheduler=args.scheduler, workers=args.workers, progress=_progress,
                                         path=volume.source)
    return marching_cubes_chunked(volume.data, level, volume.spacing, descent, chunks, progress=_progress)


def _export_open_options(args) -> dict:
    """An export that is not chunked hands an in-memory volume to one extractor: a file whose header
    says it is bigger is refused from the header, before gigabytes are read for nothing. One on a dask
    cluster maps a raw file whatever its size, so its workers read it by name."""
    if args.workers is not None or args.scheduler is not None:
        return {"map_files": True}
    if args.chunk is not None:
        return {}
    from ..core.layout import MAX_WORDS, WORD_BITS, fits_one_extraction
    return dict(fits=fits_one_extraction,
                fits_refusal=f"more than one extraction takes ({MAX_WORDS * WORD_BITS:,}, in rows of whole "
                             f"{WORD_BITS}-sample words): export it a chunk at a time (--chunk 128), or crop or "
                             "downsample it")


def run_export(args) -> int:
    if args.labels:
        return _export_labels(args)
    _check_label_options(args, "--one-file", "--max-labels")
    _check_workers(args)
    from ..io.export import in_volume_space, mesh_format, write_mesh
    mesh_format(args.out)  # an unknown extension or fraction is refused before any work
    if args.decimate is not None:
        from ..cpu.decimate import check_fraction
        check_fraction(args.decimate)
    volume = open_volume_from_args(args.volume, args, _progress, **_export_open_options(args))
    isos = _checked_levels(volume, args.iso)
    for iso in isos:
        verts, faces, normals, _ = _extract_for_export(volume, iso, args)
        if args.decimate is not None:
            verts, faces, normals = _decimated(volume, iso, verts, faces, args.decimate)
        verts, faces, normals, space = in_volume_space(volume, verts, faces, normals, world=args.space == "world")
        out = args.out if len(isos) == 1 else level_path(args.out, iso)
        path = write_mesh(out, verts, faces, normals, space=space)
        _wrote(path, f": {len(verts):,} vertices, {len(faces):,} triangles, in {space} coordinates")
    return 0


def _export_labels(args) -> int:
    from ..labels import DEFAULT_MAX_LABELS, TooManyLabels, check_label_output, label_file, write_label_meshes
    _check_label_options(args, "--iso", "--decimate")
    for option in ("--chunk", "--workers", "--scheduler"):
        if getattr(args, option.strip("-")) is not None:
            raise ValueError(f"export --labels makes every label's surface here, from the whole volume; "
                             f"leave out {option}")
    check_label_output(args.out, args.one_file)
    volume = open_volume_from_args(args.volume, args, _progress)
    limit = DEFAULT_MAX_LABELS if args.max_labels is None else args.max_labels
    try:
        written = write_label_meshes(volume, args.out, one_file=args.one_file, world=args.space == "world",
                                     max_labels=limit)
    except TooManyLabels as exc:
        would = (f"one file holding {exc.count} meshes" if args.one_file else
                 f"{exc.count} files ({label_file(args.out, 'N').name})")
        raise ValueError(f"{volume.name} has {exc.count} distinct non-zero values, more than --max-labels {limit}: "
                         f"--labels would write {would}; if it is a scan, not a segmentation, leave out --labels; "
                         f"if it is a label map, raise the limit with --max-labels {exc.count}") from None
    space = volume.world[1] if args.space == "world" and volume.world is not None else "index x spacing"
    for path, n_vertices, n_triangles in written:
        _wrote(path, f": {n_vertices:,} vertices, {n_triangles:,} triangles, in {space} coordinates")
    return 0


def _decimated(volume, iso, verts, faces, fraction):
    from ..cpu.decimate import decimate, distance_off_level_set, open_edges
    level = volume.value_range[0] + (volume.value_range[1] - volume.value_range[0]) / 2 if iso is None else iso
    full_triangles, full_open = len(faces), open_edges(faces)
    verts, faces, normals = decimate(verts, faces, fraction)
    off = distance_off_level_set(volume.checked.data, volume.spacing, level, verts)  # a lazy volume read whole
    print(f"decimated {full_triangles:,} -> {len(faces):,} triangles; distance off the level set: "
          f"max {off.max():.3g}, mean {off.mean():.3g} (world units; voxel {min(volume.spacing):.3g})")
    now_open = open_edges(faces)
    if now_open > full_open:
        print(f"note: the decimated mesh has {now_open} open edges where the full mesh had {full_open}",
              file=sys.stderr)
    return verts, faces, normals


def run_volumes(args) -> int:
    from ..volumes import describe_builtins
    rows = describe_builtins()
    width = max(len(name) for name, _ in rows)
    for name, description in rows:
        marker = " (default)" if name == DEFAULT_VOLUME else ""
        print(f"{name:<{width}}  {description}{marker}")
    return 0


RUNNERS = {"render": run_render, "export": run_export, "volumes": run_volumes}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in COMMANDS:
        command, rest = argv[0], argv[1:]
        args, runner = command_parser(command).parse_args(rest), RUNNERS[command]
    else:
        args, runner = viewer_parser().parse_args(argv), run_viewer
    from ..big.cluster import ClusterError
    from ..gpu.context import GLUnavailable
    try:
        return runner(args)
    except ClusterError as exc:
        print(f"isoscope: error: {exc}", file=sys.stderr)
        return exc.exit_status  # 2 for an address that is no dask scheduler: the input
    except (VolumeError, ValueError) as exc:
        # VolumeError and the extractor's ValueErrors carry one-line, user-facing messages.
        print(f"isoscope: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT):  # the disk (or a size limit) is full
            print(f"isoscope: error: {exc.strerror}: the output did not fit, and no partial file was left; "
                  "free disk space or write it elsewhere", file=sys.stderr)
            return EXIT_CLUSTER_FAILED
        print(f"isoscope: error: {exc.strerror or exc}: {exc.filename or ''}; check the path and its permissions",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except GLUnavailable as exc:
        print(f"isoscope: {exc}", file=sys.stderr)
        return EXIT_NO_GL
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
