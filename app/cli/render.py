"""`isoscope` (the window) and `isoscope render` (a PNG, offscreen)."""
from __future__ import annotations

import sys

from ..errors import InputError
from ..viewer.model.raycast import check_transfer_mode
from .common import EXIT_NO_GL, LABEL_MESH_FLAGS, check_label_options, checked_iso, checked_levels, progress, wrote
from .slice_options import apply_slice_arguments
from .volume_options import open_volume_from_args

DEFAULT_RENDER_SIZE = (800, 600)


def run_viewer(args) -> int:
    """Plain ``isoscope [VOLUME]``: open the viewer's window on the volume (or a scene file) and run it until it is
    closed; the exit status."""
    # Sample expr: volumes with numpy here: a GPU sampler would make an EGL context current,
    # and GLX then refuses the window's context in this process (X_GLXMakeCurrent BadAccess).
    # Inside the window the panel samples on the GPU, in the window's own context.
    from ..viewer.model.scene_file import apply_scene, is_scene_file, read_scene, volume_spec
    scene = read_scene(args.volume) if is_scene_file(args.volume) else None   # `isoscope scene.json`
    if scene is not None:
        from ..volumes import open_volume
        spec, options = volume_spec(scene)
        volume, iso = open_volume(spec, progress=progress, backend="cpu", **options), None
    else:
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
        if scene is not None:
            apply_scene(scene, window.state, window.camera)
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
        check_label_options(args, *LABEL_MESH_FLAGS)
        state.show_labels(names=args.label_names, force=args.force_labels)
    else:
        check_label_options(args, "--label-names", "--force-labels")
    if args.tetrahedra:
        state.set_cells("tetrahedra")
    if args.topology:
        state.set_topology(args.topology)
    if args.smooth:
        state.set_smooth(args.smooth)
    if args.sharp is not None:
        state.set_sharp(args.sharp)
    state.closed = args.closed   # a label's surface is closed at the border already


def run_render(args) -> int:
    """``isoscope render``: draw one volume or one scene offscreen to a PNG (sizes checked before a GL context is made
    and again against the driver's limits); the exit status."""
    from ..viewer.model.scene_file import is_scene_file, read_scene, scene_size
    from ..viewer.ui.headless import check_render_size
    if (args.scene is None) == (args.volume is None):
        raise InputError("render draws one VOLUME or one --scene JSON: give either, not both")
    if args.scene is not None:
        scene, args.volume = read_scene(args.scene), args.scene   # render --scene scene.json
    else:
        scene = read_scene(args.volume) if is_scene_file(args.volume) else None   # render scene.json
    if args.size is None:
        args.size = scene_size(scene) if scene is not None else DEFAULT_RENDER_SIZE
    check_render_size(args.size)  # pixels: before a GL context is made
    if scene is None:
        check_transfer_mode(args.raycast, args.transfer, flags=True)
        if args.labels:   # flags refused before a GL context is made (and where there is none)
            check_label_options(args, "--iso", "--panel", *LABEL_MESH_FLAGS)
    ctx = drawing_context("render")
    check_render_size(args.size, ctx)  # the driver's limits, before the volume is read
    if scene is not None:
        return _render_scene(scene, args)
    if args.labels:
        from ..viewer.ui.headless import render_png
        volume = open_volume_from_args(args.volume, args, progress)
        path = render_png(volume, args.out, size=args.size, azimuth=args.azimuth, elevation=args.elevation,
                          transparent=args.transparent, wireframe=args.wireframe, then=_scene_saver(args),
                          letters=args.orientation_letters,
                          prepare=lambda state: (apply_slice_arguments(state, args),
                                                 state.show_labels(names=args.label_names,
                                                                   force=args.force_labels)))
        wrote(path, f"({args.size[0]}x{args.size[1]})")
        return 0
    check_label_options(args, "--label-names", "--force-labels")
    from ..viewer.model.colormaps import check_colormap
    if args.color_by_map:
        check_colormap(args.color_by_map)  # an unknown map is refused before any work
    volume = open_volume_from_args(args.volume, args, progress)
    isos = checked_levels(volume, args.iso, args.opacity)
    if args.sharp is not None:
        for option in ("--panel", "--tetrahedra", "--smooth", "--labels", "--slice", "--clip", "--color-by",
                       "--orientation-letters", "--closed"):
            if getattr(args, option.strip("-").replace("-", "_"), None) not in (None, False, 0, []):
                raise InputError(f"render --sharp draws the one sharp-featured surface; leave out {option}")
        if len(isos) > 1:
            raise InputError("render --sharp draws one level; give one --iso")
    from ..viewer.ui.headless import render_png
    path = render_png(volume, args.out, isos, size=args.size, azimuth=args.azimuth,
                      elevation=args.elevation, panel=args.panel, transparent=args.transparent,
                      opacities=[a for values in args.opacity or [] for a in values],
                      color_by=args.color_by, colormap=args.color_by_map,
                      tetrahedra=args.tetrahedra, smooth=args.smooth, wireframe=args.wireframe,
                      topology=args.topology or "montani", sharp=args.sharp,
                      prepare=lambda state: (apply_slice_arguments(state, args), setattr(state, "closed", args.closed)),
                      then=_scene_saver(args),
                      letters=args.orientation_letters)
    wrote(path, f"({args.size[0]}x{args.size[1]})")
    return 0


def drawing_context(command: str):
    """The GL context `command` draws with: 4.3, else 4.1 core (meshes then made on the CPU); where there is
    none, GLUnavailable's one line says that export does not need one."""
    from ..gpu.context import DRAWING_GL, GLUnavailable, current_or_standalone
    try:
        return current_or_standalone(DRAWING_GL)
    except GLUnavailable as exc:
        raise GLUnavailable(f"{command} needs OpenGL 4.1 or newer (`isoscope export` does not): {exc}") from None


def _scene_saver(args):
    """After the picture is written: the panel's hint for each level that drew nothing, on stderr (a blank
    picture otherwise says nothing of why), what it shows of a volume over the memory budget, and with
    --save-scene PATH the scene of the picture, as `isoscope render PATH` redraws it."""
    def then(viewer) -> None:
        """After the picture: a note for each level that drew nothing, and the scene written where --save-scene asks."""
        from ..viewer.model.raycast import rays_note
        from ..viewer.ui.headless import empty_level_hints, shown_note
        for hint in [*empty_level_hints(viewer), shown_note(viewer), rays_note(viewer.state)]:
            if hint:
                print(f"note: {hint}", file=sys.stderr)
        if args.save_scene:
            from ..viewer.model.scene_file import scene_of, write_scene
            wrote(write_scene(args.save_scene, scene_of(viewer.state, viewer.camera, args.size)), "(scene)")
    return then


def _render_scene(scene, args) -> int:
    """render SCENE.json: the saved scene's picture (at its size, or --size); the command's other view
    options are the scene's, so giving them is refused."""
    for option in ("iso", "opacity", "color_by", "slice", "clip", "window", "level", "colormap", "azimuth",
                   "elevation", "tetrahedra", "smooth", "sharp", "labels", "label_names", "save_scene", "closed",
                   "raycast", "transfer", "with_surfaces", "topology"):
        if getattr(args, option, None) not in (None, False, 0, []):
            raise InputError(f"a scene holds the view; --{option.replace('_', '-')} does not go with {args.volume} "
                             "(open it in the window to change it, then save it again)")
    from ..viewer.gfx.screenshot import save_png
    from ..viewer.ui.headless import scene_pixels
    path = save_png(scene_pixels(scene, args.size, panel=args.panel, letters=args.orientation_letters), args.out)
    wrote(path, f"({args.size[0]}x{args.size[1]})")
    return 0
