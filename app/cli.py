"""The `isoscope` command: the viewer window, headless renders, mesh export, the list of built-ins.

Bad input ends with one line on stderr naming the problem and the fix, and
exit status 2; no traceback reaches the user.
"""
from __future__ import annotations

import argparse
import sys

from .volumes import DEFAULT_VOLUME, VolumeError, add_volume_arguments, open_volume_from_args

EXIT_BAD_INPUT = 2
EXIT_NO_GL = 1
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
                [--transparent] [--sharp DEG]
  isoscope export VOLUME --out mesh.ply|.obj|.stl|.glb|.off [--iso V] [--sharp DEG]
  isoscope volumes          list the built-in volumes
"""

VOLUME_HELP = ("a built-in name (isoscope volumes), a file (.npy .npz .nrrd .nii .nii.gz .tif .raw), a DICOM folder, "
               "or expr:FORMULA, e.g. 'expr:x^2+y^2+z^2-0.5'")


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line that points at --help."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def window_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size {text!r} is not WIDTHxHEIGHT, e.g. 800x600") from None
    if not (16 <= width <= 16384 and 16 <= height <= 16384):
        raise argparse.ArgumentTypeError(f"size {text!r} must be between 16x16 and 16384x16384 pixels")
    return width, height


def _add_iso(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--iso", type=float, metavar="V",
                        help="iso value (default: the volume's suggested level, else mid-range)")


def feature_angle(text: str) -> float:
    from .reference_sharp import check_feature_angle
    try:
        return check_feature_angle(float(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--sharp {text} must be a feature angle in degrees between 0 and 180 "
                                         "(exclusive), e.g. 30") from None


def _add_sharp(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--sharp", type=feature_angle, metavar="DEG",
                        help="sharp edges and corners (Extended Marching Cubes) where normals open wider than DEG "
                             "degrees, e.g. 30")


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
    parser.add_argument("--screenshot-dir", default=".", metavar="DIR",
                        help="where key s saves PNGs (default: the current directory)")
    parser.add_argument("--frames", type=int, metavar="N",
                        help="quit after drawing N frames (scripts, benchmarks, smoke tests)")
    parser.add_argument("--msaa", type=int, choices=(0, 2, 4, 8), metavar="N",
                        help="multisampling, samples per pixel: 0, 2, 4 or 8 (default 4 on a GPU, "
                             "0 on software OpenGL such as llvmpipe, where it costs 3x the frame time)")
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
        _add_iso(parser)
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
        _add_sharp(parser)
    else:
        parser = OneLineParser(prog="isoscope export",
                               description="Extract the isosurface and write it as a mesh file: binary PLY, OBJ, "
                                           "binary STL, GLB (glTF) or OFF, by the extension of --out.")
        parser.add_argument("volume", metavar="VOLUME", help=VOLUME_HELP)
        _add_iso(parser)
        parser.add_argument("--out", required=True, metavar="MESH",
                            help="the file to write: .ply, .obj, .stl, .glb or .off (replaced only once complete)")
        parser.add_argument("--space", choices=("world", "voxel"), default="world",
                            help="world (default): the file's own world coordinates where it defines them "
                                 "(NIfTI: RAS; NRRD and DICOM: LPS, as 3D Slicer saves models), so the mesh "
                                 "overlays the scan; voxel: array index x spacing")
        parser.add_argument("--decimate", type=float, metavar="FRACTION",
                            help="keep about this fraction of the triangles (quadric decimation, 0 < F <= 1); "
                                 "prints how far the result strays from the level set")
        _add_sharp(parser)
    add_volume_arguments(parser)
    return parser


def _progress(fraction: float, message: str) -> None:
    # Slow loads report progress; overwrite one line on a terminal, stay quiet in logs.
    if sys.stderr.isatty():
        end = "\n" if fraction >= 1.0 else ""
        print(f"\r{message} {fraction:4.0%}\033[K", end=end, file=sys.stderr, flush=True)


def _checked_iso(volume, iso: float | None) -> float | None:
    if iso is None:
        return volume.default_level
    low, high = volume.value_range
    if not low <= iso <= high:
        raise VolumeError(f"--iso {iso:g} is outside {volume.name}'s value range {low:g} .. {high:g}; "
                          "pick a value inside it")
    return iso


def run_viewer(args) -> int:
    # Sample expr: volumes with numpy here: a GPU sampler would make an EGL context current,
    # and GLX then refuses the window's context in this process (X_GLXMakeCurrent BadAccess).
    # Inside the window the panel samples on the GPU, in the window's own context.
    volume = open_volume_from_args(args.volume, args, _progress, backend="cpu")
    iso = _checked_iso(volume, args.iso)
    from .viewer.window import ViewerWindow, WindowUnavailable
    try:
        window = ViewerWindow(volume, iso, size=args.size, screenshot_dir=args.screenshot_dir, msaa=args.msaa)
    except WindowUnavailable as exc:
        print(f"isoscope: {exc}", file=sys.stderr)
        return EXIT_NO_GL
    window.run(max_frames=args.frames)
    return 0


def run_render(args) -> int:
    volume = open_volume_from_args(args.volume, args, _progress)
    iso = _checked_iso(volume, args.iso)
    if args.sharp is not None:
        if args.panel:
            raise ValueError("--panel cannot be drawn with --sharp yet; leave one of them out")
        from .sharp_features import render_sharp_png
        path = render_sharp_png(volume, args.out, iso, args.sharp, size=args.size, azimuth=args.azimuth,
                                elevation=args.elevation, transparent=args.transparent)
        print(f"wrote {path} ({args.size[0]}x{args.size[1]})")
        return 0
    from .viewer.headless import render_png
    path = render_png(volume, args.out, iso, size=args.size, azimuth=args.azimuth,
                      elevation=args.elevation, panel=args.panel, transparent=args.transparent)
    print(f"wrote {path} ({args.size[0]}x{args.size[1]})")
    return 0


def run_export(args) -> int:
    from . import marching_cubes
    from .export import in_volume_space, mesh_format, write_mesh
    mesh_format(args.out)  # an unknown extension or fraction is refused before any work
    if args.decimate is not None:
        from .decimate import check_fraction
        check_fraction(args.decimate)
    volume = open_volume_from_args(args.volume, args, _progress)
    iso = _checked_iso(volume, args.iso)
    verts, faces, normals, _ = marching_cubes(volume.checked, iso, spacing=volume.spacing,
                                              gradient_direction=volume.gradient_direction,
                                              sharp_features=args.sharp)
    if args.decimate is not None:
        verts, faces, normals = _decimated(volume, iso, verts, faces, args.decimate)
    verts, faces, normals, space = in_volume_space(volume, verts, faces, normals, world=args.space == "world")
    path = write_mesh(args.out, verts, faces, normals)
    print(f"wrote {path}: {len(verts):,} vertices, {len(faces):,} triangles, in {space} coordinates")
    return 0


def _decimated(volume, iso, verts, faces, fraction):
    from .decimate import decimate, distance_off_level_set, open_edges
    level = volume.value_range[0] + (volume.value_range[1] - volume.value_range[0]) / 2 if iso is None else iso
    full_triangles, full_open = len(faces), open_edges(faces)
    verts, faces, normals = decimate(verts, faces, fraction)
    off = distance_off_level_set(volume.data, volume.spacing, level, verts)
    print(f"decimated {full_triangles:,} -> {len(faces):,} triangles; distance off the level set: "
          f"max {off.max():.3g}, mean {off.mean():.3g} (world units; voxel {min(volume.spacing):.3g})")
    now_open = open_edges(faces)
    if now_open > full_open:
        print(f"note: the decimated mesh has {now_open} open edges where the full mesh had {full_open}",
              file=sys.stderr)
    return verts, faces, normals


def run_volumes(args) -> int:
    from .volumes import describe_builtins
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
    from .gl_context import GLUnavailable
    try:
        return runner(args)
    except (VolumeError, ValueError) as exc:
        # VolumeError and the extractor's ValueErrors carry one-line, user-facing messages.
        print(f"isoscope: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:
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
