"""`isoscope render`'s flags for slices, window/level, colour map and the clip plane.

Parsed here without loading GL (so `--help` stays light); checked against the
volume by the state's SliceSettings once it is shown, where a slice index outside it is refused.
"""
from __future__ import annotations

import argparse

from ..viewer.model.raycast import RAYCAST_MODES
from ..viewer.model.slices import AXES


def _axis_and_value(text: str, flag: str, example: str) -> tuple[int, str]:
    axis, equals, value = text.partition("=")
    if not equals or axis.strip().lower() not in AXES or not value:
        raise argparse.ArgumentTypeError(f"{flag} {text!r} is not AXIS=VALUE with AXIS x, y or z, e.g. {example}")
    return AXES.index(axis.strip().lower()), value


def slice_spec(text: str) -> tuple[int, int]:
    """'z=32' -> (2, 32)."""
    axis, value = _axis_and_value(text, "--slice", "z=32")
    try:
        return axis, int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--slice {text!r}: the index must be a whole number, e.g. z=32") from None


def clip_spec(text: str) -> tuple[int, float, bool]:
    """'z=40' or 'z=40:+' -> (2, 40.0, True): hide the surface above index 40; 'z=40:-' hides below."""
    axis, value = _axis_and_value(text, "--clip", "z=40:+")
    position, _, side = value.partition(":")
    if side not in ("", "+", "-"):
        raise argparse.ArgumentTypeError(f"--clip {text!r}: the side must be + (hide above) or - (hide below)")
    try:
        return axis, float(position), side != "-"
    except ValueError:
        raise argparse.ArgumentTypeError(f"--clip {text!r}: the position must be a number, e.g. z=40:+") from None


def colormap_name(text: str) -> str:
    """The --colormap flag's name if isoscope has that colour map, else argparse's error naming the choices."""
    from ..viewer.model.colormaps import check_colormap
    try:
        check_colormap(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def add_slice_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the slices' and clip's flags to `parser`: --slice, --clip, --window, --level, --colormap, --no-inset."""
    group = parser.add_argument_group("slices and clip")
    group.add_argument("--slice", action="append", type=slice_spec, metavar="AXIS=INDEX",
                       help="show the slice at sample INDEX across AXIS (x, y, z = array axes 0, 1, 2), with the "
                            "isocurve on it; repeatable; the last one is also shown in 2-D at the bottom right")
    group.add_argument("--clip", type=clip_spec, metavar="AXIS=POS[:SIDE]",
                       help="hide the surface where the AXIS index is above POS (SIDE +, the default) or below it "
                            "(-); the cut is capped with the slice there")
    group.add_argument("--window", type=float, metavar="W",
                       help="slices: the width of the value range the colour map spans (default: the values' "
                            "0.5..99.5 percentiles)")
    group.add_argument("--level", type=float, metavar="L", help="slices: the value at the colour map's middle")
    group.add_argument("--colormap", type=colormap_name, metavar="NAME",
                       help="slices: a colour map of the cmap library, e.g. gray (default), bone, viridis, magma")
    group.add_argument("--no-inset", action="store_true", help="no 2-D view of the slice at the bottom right")
    group.add_argument("--raycast", choices=RAYCAST_MODES, metavar="MODE",
                       help="draw the volume itself by ray casting instead of the meshes (with them: "
                            "--with-surfaces): mip, minip or mean "
                            "(the largest, smallest or mean value along each ray, through --colormap over "
                            "--window/--level), iso (the level's first hit, no mesh made) or dvr "
                            "(emission-absorption lit by the gradient, opacity ramping up over the window); "
                            "on OpenGL 4.1 too")
    group.add_argument("--with-surfaces", action="store_true",
                       help="--raycast: draw the surfaces too; the opaque ones (and the slices) are drawn first "
                            "and end the rays (hiding what lies behind them; mip and mean cover them as much as "
                            "they are bright, minip as it is dark), the translucent ones are blended over the "
                            "volume after it")
    group.add_argument("--transfer", metavar="V:A,...|PRESET",
                       help="--raycast dvr: the opacity at each value, linear between the points, e.g. "
                            "200:0,500:0.5,1200:1, or a preset: ct-bone, ct-soft (Hounsfield units), mri")


def apply_slice_arguments(state, args: argparse.Namespace) -> None:
    """Set the flags on a ViewerState showing the volume; a ValueError with its one line if one does not
    fit.  --window/--level are the field's words: the window's width and centre."""
    slices = state.slices
    for axis, index in args.slice or ():
        slices.show(axis, True, index)
    if args.clip is not None:
        slices.set_clip(*args.clip)
    if args.window is not None or args.level is not None:
        slices.set_window(args.window, args.level)
    if args.colormap is not None:
        slices.set_colormap(args.colormap)
    slices.inset = not args.no_inset
    if getattr(args, "raycast", None) is not None:
        state.set_raycast(args.raycast)
    if getattr(args, "with_surfaces", False):
        state.set_with_surfaces(True)
    if getattr(args, "transfer", None) is not None:
        state.set_transfer(args.transfer)
