"""The command's parsers: its flags, their types and the one-line refusal of a bad one (exit 2)."""
from __future__ import annotations

import argparse
import sys

from ..core.numbers import AZIMUTH, ELEVATION, MAX_LABELS, SMOOTH, WINDOW_FRAMES
from ..errors import InputError
from ..volumes import DEFAULT_VOLUME
from .common import EXIT_BAD_INPUT
from .slice_options import add_slice_arguments
from .volume_options import add_volume_arguments

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
                [--sharp DEG] [--closed] [--time N|all|A:B]
  isoscope export SEGMENTATION --labels --out seg.stl      one mesh per label: seg_label<N>.stl
                [--chunk N] [--workers N] [--scheduler ADDRESS]   big volumes, a chunk at a time
  isoscope measure VOLUME [--iso V ...] [--labels] [--closed] [--json]   area, volume, pieces, box
  isoscope volumes          list the built-in volumes
"""


VOLUME_HELP = ("a built-in name (isoscope volumes), a saved scene (.json), "
               "a file (.npy .npz .nrrd .nii .nii.gz .tif .raw), a DICOM folder, "
               "a Zarr or OME-Zarr folder, a quoted pattern of 3-D files as a series ('run/field_*.npy'), "
               "or expr:FORMULA, e.g. 'expr:x^2+y^2+z^2-0.5'")


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line that points at --help.

    A VOLUME path that starts with '-' goes after '--' (`isoscope export --out m.stl -- -scan.npy`);
    options may follow it too (`isoscope export -- -scan.npy --out m.stl`): VOLUME is the one positional,
    so the word right after '--' is it."""

    _given: list[str] = []

    def parse_args(self, args=None, namespace=None):
        """Parse `args` (default: the command line) with a VOLUME after ``--`` put back in its place; a usage error
        exits through `error`."""
        self._given = list(sys.argv[1:] if args is None else args)
        return super().parse_args(volume_after_dashes(self._given), namespace)

    def error(self, message: str):
        """Exit with status 2 and one escaped line, "isoscope: error: ... (see PROG --help)"; a stray option that stood
        where VOLUME goes is named, with the ``--`` that takes it as a path."""
        stray = self._stray_option() if "VOLUME" in message else None
        if stray is not None:
            message += (f"; {stray!r} is not an option: a path that starts with '-' goes after '--', e.g. "
                        f"{self.prog} ... -- {stray}")
        # "isoscope: error:" as every other refusal, whichever subcommand: scripts look for one prefix.
        from ..core.opener import shown  # a flag's value may carry ESC or a newline: one line, escaped
        self.exit(EXIT_BAD_INPUT, f"isoscope: error: {shown(message)} (see {self.prog} --help)\n")

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
    """The --size flag's WxH as (width, height), or argparse's error with the range it takes."""
    from ..core.numbers import image_size
    try:
        return image_size(text, "--size")
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


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


smooth_iterations = SMOOTH.argument()


def feature_angle(text: str) -> float:
    """The --sharp flag's feature angle in degrees (between 0 and 180), or argparse's error saying so."""
    from ..core.sharp.features import check_feature_angle
    try:
        return check_feature_angle(float(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--sharp {text} must be a feature angle in degrees between 0 and 180 "
                                         "(exclusive), e.g. 30") from None


def memory_budget(text: str) -> int:
    """The --memory-budget flag's size ("2G", "512M", bytes) in bytes, or argparse's error in the API's words."""
    from ..core.budget import BudgetError, parse_size  # the API's rule, in the flag's words
    try:
        return parse_size(text, "--memory-budget")
    except BudgetError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _add_memory_budget(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--memory-budget", type=memory_budget, metavar="SIZE",
                        help="the memory a volume on show may take, e.g. 4G or 512M (default: the GPU's free "
                             "memory where the driver reports it, else 2G; half the free RAM on a software "
                             "renderer such as llvmpipe); a volume over it is shown at every Nth sample")


max_labels = MAX_LABELS.argument()


def _add_sharp(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--sharp", type=feature_angle, metavar="DEG",
                        help="sharp edges and corners (Extended Marching Cubes) where normals open wider than DEG "
                             "degrees, e.g. 30")


def add_topology(parser: argparse.ArgumentParser) -> None:
    """Add --topology (montani or trilinear) to `parser`."""
    from ..options import TOPOLOGIES
    parser.add_argument("--topology", choices=TOPOLOGIES,
                        help="how ambiguous cells are decided: montani (default: every ambiguous face one way, "
                             "fast) or trilinear (the field's own topology between the samples, MC33: pieces, "
                             "cavities and handles as the data has them)")


def _add_closed(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--closed", action="store_true",
                        help="cap each surface where it leaves the volume, watertight there (as export --closed; a "
                             "label's surface is closed already); the panel's 'closed at the border'")


def _add_label_names(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--label-names", metavar="FILE",
                        help="with --labels: names and colours from an ITK-SNAP label description or a 3D Slicer "
                             "colour table (default: SEGMENTATION's stem + .ctbl, .txt or _label_description.txt)")


def _add_mesh_modes(parser: argparse.ArgumentParser, labels: str) -> None:
    """The flags that choose what surface is made: cells, smoothing, sharp features, a label map."""
    _add_tetrahedra(parser)
    add_topology(parser)
    _add_smooth(parser)
    _add_sharp(parser)
    parser.add_argument("--labels", action="store_true",
                        help=f"VOLUME is a label map (a segmentation): {labels}")
    add_force_labels(parser)


def add_force_labels(parser) -> None:
    """Add --force-labels (take VOLUME as a label map even where it looks like a scan) to `parser`."""
    parser.add_argument("--force-labels", action="store_true",
                        help="with --labels: take VOLUME as a label map even where it looks like a scan (its "
                             "neighbouring voxels mostly differ, where a segmentation's labels fill flat regions)")


class VersionAction(argparse.Action):
    """--version: the package's version, the OpenGL context to be had here and which extractor makes meshes
    (GL is asked only when the flag is given: `isoscope --help` loads none)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from .. import __version__
        from ..gpu.context import describe
        print(f"isoscope {__version__}\n{describe()}")
        parser.exit(0)


def viewer_parser() -> argparse.ArgumentParser:
    """The parser of plain ``isoscope [VOLUME]``, which opens the viewer (the built-in default volume without one)."""
    parser = OneLineParser(
        prog="isoscope",
        description="Live GPU isosurfaces of 3-D scalar fields. With no VOLUME, opens the viewer on "
                    f"the built-in '{DEFAULT_VOLUME}' volume.",
        epilog=KEYS_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("volume", nargs="?", default=DEFAULT_VOLUME, metavar="VOLUME", help=VOLUME_HELP)
    parser.add_argument("--version", action=VersionAction,
                        help="print the version, the OpenGL version here and which extractor (GPU or CPU) is used")
    _add_iso(parser)
    parser.add_argument("--size", type=window_size, default=(1280, 800), metavar="WxH",
                        help="window size in screen units (default 1280x800)")
    _add_mesh_modes(parser, labels="each non-zero label's surface in its own colour, listed in the panel")
    _add_closed(parser)
    _add_label_names(parser)
    parser.add_argument("--screenshot-dir", default=".", metavar="DIR",
                        help="where key s saves PNGs (default: the current directory)")
    parser.add_argument("--screenshot-scale", type=int, default=1, choices=range(1, 9), metavar="N",
                        help="key s saves the scene at N times the window's pixels, 1-8 (default 1: the "
                             "window as shown, panel included; above 1 the scene alone, for print)")
    parser.add_argument("--frames", type=WINDOW_FRAMES.argument(), metavar="N",
                        help="quit after drawing N frames (scripts, benchmarks, smoke tests)")
    parser.add_argument("--msaa", type=int, choices=(0, 2, 4, 8), metavar="N",
                        help="multisampling, samples per pixel: 0, 2, 4 or 8 (default 4 on a GPU, "
                             "0 on software OpenGL such as llvmpipe, where it costs 3x the frame time)")
    add_slice_arguments(parser)
    _add_memory_budget(parser)
    add_volume_arguments(parser)
    return parser


def command_parser(command: str) -> argparse.ArgumentParser:
    """The parser of subcommand `command`: volumes, render or export."""
    if command == "volumes":
        return OneLineParser(prog="isoscope volumes", description="List the built-in volumes.")
    if command == "render":
        parser = OneLineParser(
            prog="isoscope render",
            description="Render the viewer's scene to a PNG with no window or display (EGL).")
        add_render_options(parser, out_help="the PNG file to write", scenes=True)
        _add_closed(parser)
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
                                 "(NIfTI: RAS; NRRD and DICOM: LPS, as 3D Slicer saves models; OME-Zarr: its "
                                 "scale and translation), so the mesh "
                                 "overlays the scan; voxel: array index x spacing")
        parser.add_argument("--closed", action="store_true",
                            help="cap the surface where it leaves the volume, so the mesh is watertight (for "
                                 "3-D printing and volumes)")
        parser.add_argument("--decimate", type=float, metavar="FRACTION",
                            help="keep about this fraction of the triangles (quadric decimation, 0 < F <= 1); "
                                 "prints how far the result strays from the level set")
        _add_mesh_modes(parser, labels="one closed surface per non-zero label, neighbours sharing their "
                                       "boundary vertices, written to STEM_label<N>.EXT beside --out "
                                       "(e.g. seg.stl -> seg_label1.stl, seg_label2.stl)")
        parser.add_argument("--one-file", action="store_true",
                            help="with --labels: all labels in the one --out file (.ply or .glb), each vertex "
                                 "in its label's colour")
        _add_label_names(parser)   # --one-file's vertex colours
        parser.add_argument("--max-labels", type=max_labels, metavar="N",
                            help="with --labels: refuse a volume of more than N labels (default 255), before "
                                 "writing anything: a scan given --labels by mistake has one per grey value")
        add_big_volume_arguments(parser)
    add_volume_arguments(parser)
    return parser


def add_render_options(parser: argparse.ArgumentParser, out_help: str, out_metavar: str = "PNG",
                       scenes: bool = False) -> None:
    """What `render` draws and how: the volume, levels and their look, --out, size, camera, slices, mesh
    modes (`movie` takes the same); with `scenes`, VOLUME may be left out for --scene JSON."""
    parser.add_argument("volume", metavar="VOLUME", help=VOLUME_HELP, **({"nargs": "?"} if scenes else {}))
    if scenes:
        parser.add_argument("--scene", metavar="JSON", help="draw a saved scene (the same as giving it as VOLUME)")
    _add_iso(parser, "; repeat for several surfaces (up to 4)")
    _add_levels_look(parser)
    parser.add_argument("--out", required=True, metavar=out_metavar, help=out_help)
    parser.add_argument("--size", type=window_size, metavar="WxH",
                        help="image size in pixels (default 800x600, or a scene's own)")
    parser.add_argument("--azimuth", type=AZIMUTH.argument(), metavar="DEG",
                        help="camera angle around the vertical (z) axis, degrees (default -60); for a scan with "
                             "a patient frame (NIfTI, NRRD, DICOM) around its superior axis: -90, the default, "
                             "looks from anterior, 0 from the left, 90 from posterior")
    parser.add_argument("--elevation", type=ELEVATION.argument(), metavar="DEG",
                        help="camera angle above the x-y plane, degrees, -90..90 (default 25; 0 for a scan: "
                             "above its axial plane, superior up)")
    parser.add_argument("--panel", action="store_true", help="draw the imgui panel over the scene")
    parser.add_argument("--transparent", action="store_true",
                        help="a transparent background: an RGBA PNG, for slides and figures")
    parser.add_argument("--wireframe", action="store_true", help="draw the triangles' edges over the surface")
    parser.add_argument("--orientation-letters", action="store_true",
                        help="a scan's anatomical letters (R/L, A/P, S/I) at the picture's edges (and its 2-D "
                             "slice view's); --panel draws them anyway")
    add_slice_arguments(parser)
    _add_mesh_modes(parser, labels="draw each non-zero label's surface in its own colour")
    _add_label_names(parser)
    _add_memory_budget(parser)
    parser.add_argument("--save-scene", metavar="JSON",
                        help="also write the scene drawn (volume, levels, colours, camera, slices, modes) as JSON: "
                             "`isoscope render JSON --out PNG` redraws it, `isoscope JSON` opens it")


def add_big_volume_arguments(parser) -> None:
    """Add export's big-volume flags to `parser`: --chunk, and --workers or --scheduler for a dask cluster."""
    parser.add_argument("--chunk", type=int, metavar="N",
                        help="extract N^3-cell chunks one at a time and stitch them (the same mesh, in memory "
                             "bounded by the chunk); the default for Zarr volumes (128)")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="run the chunks on a local dask cluster of N worker processes (pip install "
                             "'isoscope[big]')")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run the chunks on the dask cluster whose scheduler is at ADDRESS "
                             "(e.g. tcp://10.0.0.5:8786); its workers must reach the volume's path")
