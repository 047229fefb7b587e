"""Direct volume rendering: the volume itself drawn by ray casting in a fragment shader (shaders/raycast.*),
one ray per pixel of the volume's box, so it needs no compute shaders and runs on OpenGL 4.1 (macOS) too.

The volume goes to a 3-D texture in its own sample type where GL has one that keeps it exactly (8- and
16-bit integers as normalised textures, mapped back to their values in the shader), float32 otherwise;
the texture is made again only when another volume comes on show.  One program per mode (MODE_MIP, ...:
a #define), compiled the first time the mode is drawn.  This object owns its GL objects; `release` frees them.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...core.value_ranges import MACRO, brick_ranges, coarser_ranges, widened
from ...core.value_ranges import RANGE_BRICK as BRICK
from ...resources import shader_source
from ..model.colormaps import LUT_SIZE
from ..model.raycast import texture_samples, texture_type, value_map
from .ray_atlas import RayAtlas
from .slices import colormap_rgba8

TRANSFER_SIZE = 1024    # entries of the transfer function's opacity table over the value range
STEP_PER_SAMPLE = 0.5   # the ray's step: half the smallest sample spacing (no sample's peak is stepped over)
COARSE = 2             # while the view moves: by default one ray per 2 x 2 pixels, stretched (a quarter of the work)
MOVING_STEP = 2.0      # while the view moves: the ray's step this many times longer (iso bisects its hit all the same)
DENSITY_PER_SAMPLE = 0.15   # DVR: extinction per sample spacing at the top of the ramp (a few samples' depth)
GRADIENT_FLOOR = 1e-3   # DVR: a sample changing less than this part of the value range per spacing is unlit


def _outward(triangles: np.ndarray) -> np.ndarray:
    """The unit cube's triangles, each wound counter-clockwise seen from outside (GL's front faces)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), (a + b + c) / 3 - 0.5) < 0
    triangles[inward] = triangles[inward][:, ::-1]
    return triangles.reshape(-1, 3)


CUBE = _outward(np.array([(x, y, z) for face in (
    ((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)), ((0, 0, 1), (0, 1, 1), (1, 1, 1), (1, 0, 1)),
    ((0, 0, 0), (0, 1, 0), (0, 1, 1), (0, 0, 1)), ((1, 0, 0), (1, 0, 1), (1, 1, 1), (1, 1, 0)),
    ((0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)), ((0, 1, 0), (1, 1, 0), (1, 1, 1), (0, 1, 1)))
    for x, y, z in (face[0], face[1], face[2], face[0], face[2], face[3])], np.float32).reshape(-1, 3, 3))


@dataclass(frozen=True)
class RaycastRequest:
    """What to ray-cast: the samples (axis 0 drawn as x) and their spacing, the mode, the level (iso), the
    window mapped to the colour map's ends, the colour map, the object's side and the surface colour (iso)."""
    data: object
    spacing: tuple[float, float, float]
    mode: str
    level: float
    window: tuple[float, float]
    colormap: str
    inside_above: bool
    color: tuple[float, float, float]
    clip_plane: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)   # kept where >= 0 (slices.py)
    transfer: tuple | None = None        # DVR: (value, opacity) points (model/raycast.py); None: the ramp
    value_range: tuple[float, float] = (0.0, 1.0)
    with_surfaces: bool = False          # the surfaces drawn too (opaque ones end the rays; renderer.py)
    lighting: bool = True                # iso's hits and DVR's samples lit as the meshes are (the panel's toggle)
    bricks: object = None                # a volume over the budget: its rays' bricks (model/ray_bricks.py)
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)   # where the samples' index 0 lies (Volume.origin)


@dataclass(frozen=True)
class SceneDepth:
    """What is drawn opaque before the rays, as a depth texture of the viewport's pixels: a ray ends there.
    A fragment's texel is (gl_FragCoord.xy - origin) * scale (the coarse pass's pixels are larger);
    `multisampled`: a multisample texture, its first sample read (no resolve)."""
    texture: object
    origin: tuple[float, float] = (0.0, 0.0)
    scale: tuple[float, float] = (1.0, 1.0)
    multisampled: bool = False


class VolumeRaycaster:
    """Draws the volume on show by ray casting (MIP, mean, MinIP or DVR), its texture made again only for another
    volume."""

    def __init__(self, ctx):
        self.ctx = ctx
        self._programs: dict[tuple[str, bool], object] = {}
        self._cube = ctx.buffer(CUBE.tobytes())
        self._vaos: dict[str, object] = {}
        self._texture = None
        self._ranges = None              # each brick's (min, max): empty space skipped
        self._macro_ranges = None        # each macro brick's (MACRO^3 bricks)
        self._bricks = self._macros = (1, 1, 1)
        self._texture_of = None          # the data array the textures hold
        self._value_map = (1.0, 0.0)
        self._lut = ctx.texture((LUT_SIZE, 1), 4)
        self._lut.repeat_x = self._lut.repeat_y = False
        self._lut_name: str | None = None
        self._transfer = ctx.texture((TRANSFER_SIZE, 1), 1, dtype="f4")
        self._transfer.repeat_x = self._transfer.repeat_y = False
        self._transfer.filter = (ctx.LINEAR, ctx.LINEAR)
        self._transfer_of = None
        self._base_ranges = None         # the volume's bricks' (min, max), before the atlas's widen them
        self._ranges_of = None           # (atlas, its changes) the ranges' textures are widened for
        self._atlas: RayAtlas | None = None   # a volume over the budget: its bricks at full resolution
        self._coarse = None              # (framebuffer, colour texture, depth) of the moving view's picture
        self._upscale = None             # the program stretching it over the viewport

    def _program(self, key: tuple[str, bool, bool]):
        """The program of (mode, whether the scene's depth is multisampled, whether bricks are read at full
        resolution) and its vertex array."""
        if key not in self._programs:
            mode, multisampled, bricked = key
            define = {f"MODE_{mode.upper()}": 1, **({"DEPTH_MULTISAMPLE": 1} if multisampled else {}),
                      **({"BRICKED": 1} if bricked else {})}
            program = self.ctx.program(vertex_shader=shader_source("raycast.vert"),
                                       fragment_shader=shader_source("raycast.frag", define))
            self._programs[key] = program
            self._vaos[key] = self.ctx.vertex_array(program, [(self._cube, "3f", "in_position")])
        return self._programs[key], self._vaos[key]

    def _upload(self, data) -> None:
        """The volume's samples into the 3-D texture (again only for another array)."""
        if self._texture is not None and self._texture_of is data:
            return
        self._release_volume()
        array = np.asarray(data)
        ranges = brick_ranges(array, BRICK)
        macro_ranges = coarser_ranges(ranges, MACRO)
        self._bricks, self._macros = ranges.shape[:3], macro_ranges.shape[:3]
        self._base_ranges = ranges
        self._ranges, self._macro_ranges = (self.ctx.texture3d(r.shape[2::-1], 2, np.ascontiguousarray(r).tobytes(),
                                                               dtype="f4") for r in (ranges, macro_ranges))
        kind = texture_type(array.dtype)[0]
        samples = texture_samples(array)
        self._texture = self.ctx.texture3d(samples.shape[::-1], 1, samples.tobytes(), dtype=kind)
        self._texture.filter = (self.ctx.LINEAR, self.ctx.LINEAR)   # the trilinear interpolant
        self._texture.repeat_x = self._texture.repeat_y = self._texture.repeat_z = False
        self._texture_of, self._value_map = data, value_map(array.dtype)

    def draw(self, request, view: bytes, projection: bytes, eye, depth: SceneDepth | None = None,
             step_scale: float = 1.0) -> None:
        """Draw `request` (a RaycastRequest; its mode checked by the state, model/raycast.py) into the bound
        framebuffer under the camera's matrices, blended over what is there (premultiplied); `depth`: where
        what is drawn opaque ends the rays; `step_scale`: the ray's step that many times STEP_PER_SAMPLE's.
        Only iso writes depth (its hit), tested against what is drawn."""
        ctx = self.ctx
        self._upload(request.data)
        atlas = self._follow_bricks(request.bricks)
        if request.colormap != self._lut_name:
            self._lut.write(colormap_rgba8(request.colormap).tobytes())
            self._lut_name = request.colormap
        program, vao = self._program((request.mode, depth is not None and depth.multisampled, atlas is not None))
        shape = np.array(request.data.shape, np.float64)
        spacing = np.array(request.spacing, np.float64)
        texture_extent = (shape - 1) * spacing
        origin = np.array(request.origin, np.float64)   # the box is [origin, extent]: the samples' own place
        extent = origin + texture_extent
        step = STEP_PER_SAMPLE * step_scale * spacing.min()
        # DVR's extinction and its gradient floor are per sample spacing of the volume: of the full volume's where
        # it is shown in bricks, so a picture keeps its opacity as its bricks come in full
        unit = float(min(request.bricks.volume.spacing) if request.bricks is not None else spacing.min())
        bricked = {}
        if atlas is not None:   # stepped at the full volume's spacing where it is read in full
            model = request.bricks
            fine = np.array(model.volume.spacing, np.float64)
            # the box drawn, the bounds and the camera's are the coarse view's (a few full samples short of the
            # full volume's far faces where its step does not divide them): so are the rays'
            extent = np.minimum(extent, (np.array(model.volume.data.shape, np.float64) - 1) * fine)
            origin = np.maximum(origin, 0.0)
            moving = step_scale > 1.0   # the moving view's pass: the coarse view's step throughout, bricks read
            step = step if moving else STEP_PER_SAMPLE * step_scale * fine.min()
            bricked = {"u_atlas_shape": tuple(float(n) for n in atlas.shape), "u_atlas_value_map": atlas.value_map,
                       "u_fine_spacing": tuple(fine), "u_cells": float(model.layout.cells),
                       "u_grid": tuple(float(n) for n in model.grid),
                       "u_coarse_steps": 1.0 if moving else float(model.layout.step),
                       "u_range_cells": float(atlas.range_cells), "u_slot_ranges": float(atlas.slot_ranges),
                       "u_atlas": 7, "u_slots": 8, "u_atlas_ranges": 9}
            atlas.use(7, 8, 9)
        uniforms = {**bricked, "u_extent": tuple(extent), "u_texture_extent": tuple(texture_extent),
                    "u_box_low": tuple(origin), "u_texture_origin": tuple(float(o) for o in request.origin),
                    "u_shape": tuple(shape), "u_eye": tuple(float(v) for v in eye), "u_step": float(step),
                    "u_value_map": self._value_map,
                    "u_window": tuple(request.window), "u_level": float(request.level),
                    "u_inside": 1.0 if request.inside_above else -1.0,
                    "u_density": float(DENSITY_PER_SAMPLE / unit), "u_front_color": tuple(request.color),
                    "u_brick": tuple(BRICK * spacing), "u_bricks": tuple(float(n) for n in self._bricks),
                    "u_macro": tuple(MACRO * BRICK * spacing), "u_macros": tuple(float(n) for n in self._macros),
                    "u_macro_ranges": 6,
                    "u_clip_plane": tuple(request.clip_plane), "u_volume": 0, "u_colormap": 1, "u_ranges": 2,
                    "u_transfer": 4, "u_transfer_on": 0.0 if request.transfer is None else 1.0,
                    "u_transfer_range": tuple(request.value_range),
                    "u_transfer_floor": transparent_below(request.transfer, request.value_range),
                    "u_gradient_floor": float(GRADIENT_FLOOR * max(np.ptp(request.value_range), 1e-30) / unit),
                    "u_lighting": bool(request.lighting), "u_depth": 5, "u_depth_on": 0.0 if depth is None else 1.0,
                    "u_depth_origin": (0.0, 0.0) if depth is None else tuple(depth.origin),
                    "u_depth_scale": (1.0, 1.0) if depth is None else tuple(depth.scale)}
        if request.transfer is not None and (request.transfer, request.value_range) != self._transfer_of:
            self._transfer.write(opacity_table(request.transfer, request.value_range).tobytes())
            self._transfer_of = (request.transfer, request.value_range)
        for name, value in uniforms.items():
            if name in program:
                program[name].value = value
        program["u_view"].write(view)
        program["u_projection"].write(projection)
        if "u_inverse" in program:   # pyrr's row vectors: GL reads these bytes as (P V)^-1
            matrices = [np.frombuffer(m, np.float32).reshape(4, 4).astype(np.float64) for m in (view, projection)]
            program["u_inverse"].write(np.linalg.inv(matrices[0] @ matrices[1]).astype(np.float32).tobytes())
        if depth is not None:
            depth.texture.use(5)
        self._texture.use(0)
        self._lut.use(1)
        self._ranges.use(2)
        self._macro_ranges.use(6)
        self._transfer.use(4)
        # The box's back faces: a ray for every pixel the box covers, the eye inside the box too.
        ctx.enable(ctx.CULL_FACE)
        ctx.cull_face = "front"   # outward faces are front faces, mirrored views too (front_face follows)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA   # premultiplied over what is drawn
        if request.mode != "iso":   # the box's back faces are behind what ends the rays: no depth test
            ctx.disable(ctx.DEPTH_TEST)
        vao.render(mode=ctx.TRIANGLES)
        ctx.disable(ctx.CULL_FACE | ctx.BLEND)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.cull_face = "back"

    def follow_bricks(self, model) -> RayAtlas | None:
        """The atlas of `model`'s bricks (a RayBricks, or None) in line with it; None where there is none."""
        if self._atlas is not None and self._atlas.model is not model:
            self._release_atlas()
        if model is None or not model.capacity:
            self._release_atlas()
            return None
        if self._atlas is None:
            self._atlas = RayAtlas(self.ctx, model)
        self._atlas.follow()
        return self._atlas

    def _follow_bricks(self, model) -> RayAtlas | None:
        """follow_bricks, and the skipping ranges widened by what the atlas's bricks hold; None where no brick
        is read at full resolution."""
        atlas = self.follow_bricks(model)
        if atlas is None:
            return None
        if self._ranges_of != (atlas, atlas.changes):
            self._write_ranges(widened(self._base_ranges, [model.loaded[i].ranges for i in atlas.slots]))
            self._ranges_of = (atlas, atlas.changes)
        return atlas if atlas.any else None

    def _write_ranges(self, ranges: np.ndarray) -> None:
        """The skipping ranges (and their macro bricks') into their textures."""
        self._ranges.write(np.ascontiguousarray(ranges).tobytes())
        self._macro_ranges.write(np.ascontiguousarray(coarser_ranges(ranges, MACRO)).tobytes())

    def _release_atlas(self) -> None:
        if self._atlas is not None:
            self._atlas.release()
            self._atlas = None
            if self._ranges_of is not None and self._ranges is not None:
                self._write_ranges(self._base_ranges)
            self._ranges_of = None

    def idle(self) -> None:
        """The volume is not ray cast now: the bricks' atlas (counted in the memory budget) is freed."""
        self._release_atlas()

    def draw_coarse(self, request, view: bytes, projection: bytes, eye, viewport,
                    depth: SceneDepth | None = None, spacing: int = COARSE) -> None:
        """`draw` with one ray per `spacing` x `spacing` pixels of `viewport`, into a small target stretched over
        it (linear), for the frames while the view or the level moves, each ray stepping MOVING_STEP times
        further: about 1 / spacing^2 of the time, and less again where the rays march through what is not
        skipped (a body's soft tissue in DVR, the samples near the level in iso)."""
        ctx = self.ctx
        size = (max(1, viewport[2] // spacing), max(1, viewport[3] // spacing))
        if self._coarse is None or self._coarse[1].size != size:
            self._release_coarse()
            colour = ctx.texture(size, 4)
            colour.filter = (ctx.LINEAR, ctx.LINEAR)
            colour.repeat_x = colour.repeat_y = False
            depth_buffer = ctx.depth_texture(size)   # iso's hits, stretched with the picture
            depth_buffer.compare_func = ""   # read as depths by a plain sampler (a comparison reads 0 or 1)
            depth_buffer.filter = (ctx.NEAREST, ctx.NEAREST)
            depth_buffer.repeat_x = depth_buffer.repeat_y = False
            self._coarse = (ctx.framebuffer(color_attachments=[colour], depth_attachment=depth_buffer), colour,
                            depth_buffer)
        if self._upscale is None:
            program = ctx.program(vertex_shader=shader_source("oit_composite.vert"),
                                  fragment_shader=shader_source("raycast_upscale.frag"))
            self._upscale = (program, ctx.vertex_array(program, []))
        destination = ctx.fbo
        framebuffer, colour, _ = self._coarse
        framebuffer.use()
        ctx.viewport = (0, 0, *size)
        framebuffer.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        if depth is not None:   # a small pixel's texel: its window pixel's, less `depth`'s origin
            scale = (viewport[2] / size[0], viewport[3] / size[1])
            depth = replace(depth, origin=tuple((depth.origin[k] - viewport[k]) / scale[k] for k in (0, 1)),
                            scale=scale)
        self.draw(request, view, projection, eye, depth, MOVING_STEP)
        destination.use()
        ctx.viewport = viewport
        program, vao = self._upscale
        program["u_coarse"].value, program["u_coarse_depth"].value = 3, 10
        program["u_viewport"].value = tuple(float(v) for v in viewport)
        colour.use(3)
        self._coarse[2].use(10)
        if request.mode != "iso":   # only iso's hits have a depth: the other modes blend over all there is
            ctx.disable(ctx.DEPTH_TEST)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA
        vao.render(mode=ctx.TRIANGLES, vertices=3)
        ctx.disable(ctx.BLEND)
        ctx.enable(ctx.DEPTH_TEST)

    def _release_coarse(self) -> None:
        if self._coarse is not None:
            for obj in self._coarse:
                obj.release()
            self._coarse = None

    def release(self) -> None:
        """Free the textures, programs, vertex arrays and buffers."""
        self._release_coarse()
        self._release_volume()   # first: the atlas let go then writes no ranges into textures about to go
        self._release_atlas()
        if self._upscale is not None:
            for obj in self._upscale[::-1]:
                obj.release()
            self._upscale = None
        for vao in self._vaos.values():
            vao.release()
        for program in self._programs.values():
            program.release()
        self._vaos.clear()
        self._programs.clear()
        self._cube.release()
        self._lut.release()
        self._transfer.release()

    def _release_volume(self) -> None:
        self._ranges_of = None   # the new volume's ranges are widened again (its atlas follows its own model)
        if self._texture is not None:
            for texture in (self._texture, self._ranges, self._macro_ranges):
                texture.release()
            self._texture = self._ranges = self._macro_ranges = self._texture_of = None


def opacity_table(points, value_range) -> np.ndarray:
    """TRANSFER_SIZE float32 opacities over `value_range`, linear between the points (0 below the first,
    the last one's above the last)."""
    low, high = value_range
    values = np.linspace(low, high, TRANSFER_SIZE)
    xs, ys = (np.array(column, np.float64) for column in zip(*points))
    return np.interp(values, xs, ys, left=0.0, right=ys[-1]).astype(np.float32)


def transparent_below(points, value_range) -> float:
    """The value at or below which the transfer function is 0 (bricks all below it are skipped); below the
    range where it is not 0 at its start."""
    if points is None:
        return float(value_range[0]) - 1.0
    floor = float(value_range[0]) - 1.0
    for value, opacity in points:
        if opacity > 0.0:
            break
        floor = float(value)
    return floor


def raycast_request(state) -> RaycastRequest | None:
    """What the state asks to ray-cast (`ViewerState.raycast`), or None for the meshes: the volume on show,
    the selected level and its colour, the slices' window and colour map (--window, --level, --colormap)."""
    if state.raycast is None or state.volume is None:
        return None
    settings, level = state.slices, state.levels.current
    half = settings.window / 2
    color = level.color if level is not None and level.color is not None else state.style.front_color
    volume = state.volume
    clip = settings.clip.plane(volume.spacing, volume.origin) if settings.clip is not None else (0.0, 0.0, 0.0, 1.0)
    return RaycastRequest(state.volume.data, tuple(state.volume.spacing), state.raycast, float(state.iso),
                          (settings.centre - half, settings.centre + half), settings.colormap,
                          state.gradient_direction == "descent", tuple(color), tuple(clip), state.transfer,
                          tuple(float(v) for v in state.value_range), state.with_surfaces, state.style.lighting,
                          state.bricks.rays if state.bricks is not None else None,
                          tuple(float(o) for o in volume.origin))
