"""`isoscope` (the window) and `isoscope render` (a PNG, offscreen)."""
from __future__ import annotations

import sys

from .common import EXIT_NO_GL, check_label_options, checked_iso, checked_levels, progress, wrote
from .slice_options import apply_slice_arguments
from .volume_options import open_volume_from_args


def run_viewer(args) -> int:
    # Sample expr: volumes with numpy here: a GPU sampler would make an EGL context current,
    # and GLX then refuses the window's context in this process (X_GLXMakeCurrent BadAccess).
    # Inside the window the panel samples on the GPU, in the window's own context.
    volume = open_volume_from_args(args.volume, args, progress, backend="cpu")
    iso = checked_iso(volume, args.iso)
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


def run_render(args) -> int:
    from ..gpu.context import DRAWING_GL, GLUnavailable, current_or_standalone
    from ..viewer.ui.headless import check_render_size
    check_render_size(args.size)  # pixels: before a GL context is made
    try:
        ctx = current_or_standalone(DRAWING_GL)   # 4.3, else 4.1 core (meshes made on the CPU)
    except GLUnavailable as exc:
        raise GLUnavailable(f"render needs OpenGL 4.1 or newer (`isoscope export` does not): {exc}") from None
    check_render_size(args.size, ctx)  # the driver's limits, before the volume is read
    if args.labels:
        check_label_options(args, "--iso", "--panel")
        from ..viewer.ui.headless import render_labels_png
        volume = open_volume_from_args(args.volume, args, progress)
        path = render_labels_png(volume, args.out, size=args.size, azimuth=args.azimuth, elevation=args.elevation,
                                 transparent=args.transparent)
        wrote(path, f"({args.size[0]}x{args.size[1]})")
        return 0
    from ..viewer.model.colormaps import check_colormap
    if args.color_by_map:
        check_colormap(args.color_by_map)  # an unknown map is refused before any work
    volume = open_volume_from_args(args.volume, args, progress)
    isos = checked_levels(volume, args.iso, args.opacity)
    if args.sharp is not None:
        for option in ("--panel", "--tetrahedra", "--smooth", "--labels", "--slice", "--clip", "--color-by"):
            if getattr(args, option.strip("-").replace("-", "_"), None) not in (None, False, 0, []):
                raise ValueError(f"render --sharp draws the one sharp-featured surface; leave out {option}")
        if len(isos) > 1:
            raise ValueError("render --sharp draws one level; give one --iso")
        from ..viewer.ui.headless import render_sharp_png
        path = render_sharp_png(volume, args.out, isos[0], args.sharp, size=args.size, azimuth=args.azimuth,
                                elevation=args.elevation, transparent=args.transparent)
        wrote(path, f"({args.size[0]}x{args.size[1]})")
        return 0
    from ..viewer.ui.headless import render_png
    path = render_png(volume, args.out, isos, size=args.size, azimuth=args.azimuth,
                      elevation=args.elevation, panel=args.panel, transparent=args.transparent,
                      opacities=[a for values in args.opacity or [] for a in values],
                      color_by=args.color_by, colormap=args.color_by_map,
                      tetrahedra=args.tetrahedra, smooth=args.smooth, wireframe=args.wireframe,
                      prepare=lambda state: apply_slice_arguments(state, args))
    wrote(path, f"({args.size[0]}x{args.size[1]})")
    return 0
