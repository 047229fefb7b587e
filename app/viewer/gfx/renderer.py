"""Draws the scene: lit isosurface meshes, their wireframe overlay, the slices and the volume's bounding box.

Each mesh has a look (`SurfaceLook`): its colour, opacity and colour map; translucent
ones go through weighted blended OIT (oit.py) after the opaque scene.

Meshes are `GpuMesh` records, drawn straight from their GPU buffers (no read-back).
This module owns the scene's GL objects: programs, VAOs, the box's vertex
buffer, and the multisampled offscreen target used by headless renders.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import moderngl
import numpy as np

from ...core.layout import VERTEX_FORMAT, vertex_format
from ...errors import InputError
from ...gpu.context import is_software_renderer
from ...gpu.mesh import GpuMesh
from ...resources import shader_source
from ..model.slices import SliceScene
from ..model.style import SurfaceStyle
from .colorby import GpuColorBy
from .oit import OitTargets
from .opaque_pass import OpaquePass
from .raycast import COARSE, RaycastRequest, SceneDepth, VolumeRaycaster, raycast_request
from .slices import GL_CLIP_DISTANCE0, SliceRenderer

WIRE_COLOR = (0.02, 0.02, 0.05)
WIRE_OPACITY = 0.45
COLORMAP_UNIT, SCALAR_UNIT = 3, 4   # texture units of a look's colour map and scalar volume

SOFTWARE_DRAW_TRIANGLES = 1 << 16
"""On a software renderer, the triangles drawn between two waits for its rasterizer (65,536).  llvmpipe bins
each triangle drawn (~100-250 bytes of setup each) into scenes its threads then rasterize; the binning runs
ahead, and a frame's scenes grow with what it draws and stay allocated: 0.93 M triangles at 1280x800 took
154 MiB of RSS that no later frame gave back.  Waiting every 65,536 triangles keeps that to 11-16 MiB (640x480
to 1280x800) for ~5% of a big frame's time: 1.17 M triangles at 1280x800, 432 ms median against 410 without
waits; every 16,384 kept 6-10 MiB but took 866 ms (benchmarks/results-llvmpipe.md)."""

# The 12 edges of a box as pairs of corner indices; corner i has bit k set when axis k is at `upper`.
_BOX_EDGES = [(a, b) for a in range(8) for b in range(8) if a < b and bin(a ^ b).count("1") == 1]


@dataclass(frozen=True)
class SurfaceLook:
    """How the renderer draws one mesh: its colour, opacity, colour map, and where it is placed (`origin`, added
    to its vertices: a pyramid level's coarse view off the full level's grid, Volume.origin)."""
    color: tuple[float, float, float]
    opacity: float
    color_by: GpuColorBy | None = None
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)


class SceneRenderer:
    """Draws a frame of the scene into the framebuffer in use: the meshes in their looks (translucent ones through OIT),
    wireframes, slices, the ray-cast volume and the box."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        mesh_vert = shader_source("mesh.vert")
        self.mesh_program = ctx.program(vertex_shader=mesh_vert, fragment_shader=shader_source("mesh.frag"))
        self.wire_program = ctx.program(vertex_shader=mesh_vert, fragment_shader=shader_source("flat.frag"))
        self.oit_program = ctx.program(vertex_shader=mesh_vert,
                                       fragment_shader=shader_source("mesh.frag", {"OIT": 1}))
        for program in (self.mesh_program, self.oit_program):
            program["u_colormap"].value = COLORMAP_UNIT
            program["u_scalar"].value = SCALAR_UNIT
        self.oit = OitTargets(ctx)
        self._raycaster: VolumeRaycaster | None = None   # made the first time the volume is ray-cast
        self._opaque: OpaquePass | None = None   # the opaque scene drawn once where rays end at its depth
        self.box_program = ctx.program(vertex_shader=shader_source("box.vert"),
                                       fragment_shader=shader_source("flat.frag"))
        self.box_buffer = ctx.buffer(reserve=len(_BOX_EDGES) * 2 * 3 * 4)
        self.box_vao = ctx.vertex_array(self.box_program, [(self.box_buffer, "3f", "in_position")])
        # (vertex buffer, index buffer) -> (lit VAO, wireframe VAO), for the meshes drawn last frame.
        self._vaos: dict[tuple[moderngl.Buffer, moderngl.Buffer], tuple[moderngl.VertexArray, ...]] = {}
        self.slices = SliceRenderer(ctx)   # slice planes, the clip's cut and the 2-D view (slices.py)
        self.pacer = DrawPacer(ctx, SOFTWARE_DRAW_TRIANGLES if is_software_renderer(ctx) else 0)

    def set_box(self, lower, upper) -> None:
        """The bounding box to draw, in world units."""
        corners = np.array([[(upper if (i >> k) & 1 else lower)[k] for k in range(3)] for i in range(8)], "f4")
        self.box_buffer.write(corners[np.array(_BOX_EDGES).ravel()].tobytes())

    def _vaos_for(self, mesh: GpuMesh) -> tuple[moderngl.VertexArray, ...]:
        # An extractor may reallocate its buffers when its mesh grows: VAOs are made per buffer pair.
        key = (mesh.vertex_buffer, mesh.index_buffer)
        if key not in self._vaos:
            if mesh.vertex_format != VERTEX_FORMAT:
                raise InputError(f"the renderer cannot draw vertex records of format {mesh.vertex_format!r}")
            vbo, ibo = key
            lit = [(vbo, VERTEX_FORMAT, "in_position", "in_value", "in_normal")]
            self._vaos[key] = (
                self.ctx.vertex_array(self.mesh_program, lit, index_buffer=ibo, index_element_size=4),
                self.ctx.vertex_array(self.wire_program, [(vbo, vertex_format("position"), "in_position")],
                                      index_buffer=ibo, index_element_size=4),
                self.ctx.vertex_array(self.oit_program, lit, index_buffer=ibo, index_element_size=4))
        return self._vaos[key]

    def _release_vaos(self, keep=()) -> None:
        """Release the VAOs of buffer pairs not in `keep` (their buffers may be gone)."""
        for key in [k for k in self._vaos if k not in keep]:
            for vao in self._vaos.pop(key):
                vao.release()

    def draw(self, meshes: Sequence[GpuMesh], camera, viewport: tuple[int, int, int, int], style: SurfaceStyle,
             covered_left: int = 0, looks: Sequence[SurfaceLook] | None = None,
             slices: SliceScene | None = None, raycast: RaycastRequest | None = None,
             coarse: int = 0) -> None:
        """Clear `viewport` of the bound framebuffer and draw the box, the slices and `meshes` into it.

        `covered_left`: pixels at the left hidden by the panel; the scene centres in the rest.
        `looks`: each mesh's colour, opacity and colour map (default: opaque, the style's colour).
        `slices`: ViewerState.slice_scene; its clip plane hides the meshes on one side.
        `raycast`: the volume itself drawn by ray casting (gfx/raycast.py), in the meshes' place unless it
        asks for them too (`with_surfaces`): then the opaque surfaces and the slices are drawn first and end
        the rays (their depth), the rays are blended over them, and the translucent surfaces over both
        (OIT); `coarse`: with a ray per N x N pixels, N = `coarse` (True: 2; the window's frames while the
        view moves; 0 or False: a ray per pixel).
        """
        ctx = self.ctx
        if looks is None:
            looks = [SurfaceLook(style.front_color, 1.0)] * len(meshes)
        surfaces = raycast is None or raycast.with_surfaces
        drawn = [(mesh, look) for mesh, look in zip(meshes, looks) if mesh.n_triangles and look.opacity > 0
                 and surfaces]
        translucent = [(mesh, look) for mesh, look in drawn if look.opacity < 1]
        destination = ctx.fbo
        if translucent:   # the opaque scene goes to the OIT targets first (oit.py)
            self.oit.prepare((viewport[0] + viewport[2], viewport[1] + viewport[3]), destination.samples)
            self.oit.scene.use()
        # With rays to end, the opaque scene goes to a target of its own first (opaque_pass.py): drawn once,
        # its depth ends the rays.
        opaque = [mesh for mesh, look in drawn if look.opacity >= 1]
        ends_rays = raycast is not None and bool(opaque or (slices is not None and slices.settings.planes(
            caps=surfaces)))
        if ends_rays:
            self._opaque = self._opaque or OpaquePass(ctx)
            self._opaque.begin(viewport)
        # imgui's C++ renderer changes GL state behind moderngl's back: set all we rely on.
        ctx.viewport = viewport
        ctx.scissor = None
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<="
        ctx.wireframe = False
        ctx.polygon_offset = (0.0, 0.0)
        # A mirrored view (a scan stored left-handed, shown the patient's way round) reverses the
        # triangles' winding on screen: the outside must stay the front (mesh.frag's gl_FrontFacing).
        ctx.front_face = "cw" if camera.mirrored else "ccw"
        if style.transparent_background:  # premultiplied: read_rgba() turns it into straight alpha
            ctx.clear(0.0, 0.0, 0.0, 0.0, depth=1.0, viewport=viewport)
        else:
            ctx.clear(*style.background, 1.0, depth=1.0, viewport=viewport)

        width, height = viewport[2], viewport[3]
        view = camera.view_matrix().tobytes()
        shift_x = min(max(covered_left, 0), width // 2) / max(width, 1)
        projection = camera.projection_matrix(width / max(height, 1), shift_x).tobytes()
        for program in (self.mesh_program, self.wire_program, self.box_program, self.oit_program):
            program["u_view"].write(view)
            program["u_projection"].write(projection)

        if style.show_box:
            self.box_program["u_color"].value = style.box_color
            self.box_program["u_opacity"].value = 1.0
            self.box_vao.render(moderngl.LINES)
        # Opaque: with translucent meshes, into the OIT scene.  The clip's cut caps the surfaces: not drawn
        # for rays alone (the clip cuts them; iso draws its own cut).
        self._release_vaos(keep={(m.vertex_buffer, m.index_buffer) for m, _ in drawn})
        self.slices.draw(slices, view, projection, caps=surfaces)
        if drawn:
            self._draw_opaque(drawn, slices, style, wireframe=raycast is None)
        if raycast is not None:
            depth = None
            if ends_rays:
                ctx.disable_direct(GL_CLIP_DISTANCE0)   # a full-screen copy writes no clip distance
                depth = self._opaque.finish(viewport)
                if drawn and slices is not None and slices.settings.clip is not None:
                    ctx.enable_direct(GL_CLIP_DISTANCE0)   # for the wireframe and translucent surfaces to come
            self._draw_rays(raycast, depth, view, projection, camera, viewport, coarse)
            if drawn and style.wireframe:
                # After the rays, so their lines end no ray and show over the volume; tested against the opaque
                # depth (and iso's hits), written nowhere.  Under the translucent layers, as without rays.
                self._draw_wireframe(drawn, write_depth=False)
        elif self._raycaster is not None:
            self._raycaster.idle()   # not ray cast now: the bricks' atlas is let go
        if translucent:
            self._draw_translucent(translucent, viewport, destination)
        ctx.disable_direct(GL_CLIP_DISTANCE0)   # imgui's shaders write no clip distance

    def _draw_opaque(self, drawn, slices: SliceScene | None, style: SurfaceStyle, wireframe: bool = True) -> None:
        """The opaque meshes of `drawn` (with `wireframe`, and the style's, their wireframe over all of them), the
        clip plane set."""
        ctx = self.ctx
        for program in (self.mesh_program, self.oit_program):
            program["u_lighting"].value = style.lighting
        # mesh.vert's gl_ClipDistance[0] >= 0 is kept.  Set even with no clip: llvmpipe was seen to
        # clip by it while GL_CLIP_DISTANCE0 was disabled.
        clip = slices.settings.clip if slices is not None else None
        for program in (self.mesh_program, self.wire_program, self.oit_program):
            program["u_clip_plane"].value = (clip.plane(slices.spacing, slices.origin) if clip is not None
                                             else (0.0, 0.0, 0.0, 1.0))
        if clip is not None:
            ctx.enable_direct(GL_CLIP_DISTANCE0)
        if style.wireframe:
            # Push the filled surface back a little so its own edges win the depth test.
            ctx.polygon_offset = (1.0, 1.0)
        for mesh, look in drawn:
            if look.opacity >= 1:
                self._use_look(self.mesh_program, look, style.back_color)
                self.pacer.draw(self._vaos_for(mesh)[0], mesh.n_triangles, mesh.first_triangle)
        ctx.polygon_offset = (0.0, 0.0)
        if style.wireframe and wireframe:
            self._draw_wireframe(drawn)

    def _draw_wireframe(self, drawn, write_depth: bool = True) -> None:
        """The lines of the triangles of `drawn`'s meshes (mesh, look), translucent, depth-tested (`write_depth`:
        writing it too)."""
        ctx = self.ctx
        ctx.wireframe = True
        # Translucent lines: a dense mesh still shows the shading underneath.
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self.wire_program["u_color"].value = WIRE_COLOR
        self.wire_program["u_opacity"].value = WIRE_OPACITY
        framebuffer = ctx.fbo
        framebuffer.depth_mask = write_depth
        for mesh, look in drawn:
            self.wire_program["u_origin"].value = look.origin
            self.pacer.draw(self._vaos_for(mesh)[1], mesh.n_triangles, mesh.first_triangle)
        framebuffer.depth_mask = True
        ctx.disable(moderngl.BLEND)
        ctx.wireframe = False

    def _draw_rays(self, raycast: RaycastRequest, depth: SceneDepth | None, view, projection, camera, viewport,
                   coarse: int) -> None:
        """The volume ray cast over what is drawn, ended by `depth` (the opaque scene's, opaque_pass.py)."""
        if self._raycaster is None:
            self._raycaster = VolumeRaycaster(self.ctx)
        spacing = COARSE if coarse is True else int(coarse)
        if spacing > 1:
            self._raycaster.draw_coarse(raycast, view, projection, camera.eye(), viewport, depth, spacing)
        else:
            self._raycaster.draw(raycast, view, projection, camera.eye(), depth)

    def follow_ray_bricks(self, model) -> None:
        """The rays' bricks (model/ray_bricks.py) into their atlas now, before a frame draws them (a headless
        render reads them one by one: each goes to the GPU before the next is read)."""
        if self._raycaster is None:
            self._raycaster = VolumeRaycaster(self.ctx)
        self._raycaster.follow_bricks(model)

    def draw_scene(self, scene, camera, viewport: tuple[int, int, int, int], covered_left: int = 0,
                   coarse: int = 0) -> None:
        """What a GpuScene shows of its state: the meshes in their looks, the slices and clip, then the 2-D view."""
        drawn, slices = scene.drawn(), scene.state.slice_scene   # each worked out once a frame
        self.draw([mesh for mesh, _ in drawn], camera, viewport, scene.state.style, covered_left=covered_left,
                  looks=[look for _, look in drawn], slices=slices, raycast=raycast_request(scene.state),
                  coarse=coarse)
        self.draw_inset(slices, viewport)

    def draw_inset(self, slices: SliceScene | None, viewport: tuple[int, int, int, int]) -> None:
        """After `draw`: the 2-D view of the active slice, over the scene's bottom-right corner."""
        self.slices.draw_inset(slices, viewport)

    def _draw_translucent(self, translucent, viewport, destination) -> None:
        """OIT's steps 2 and 3 (oit.py)."""
        self.ctx.polygon_offset = (0.0, 0.0)
        self.oit.begin_translucent()
        self.ctx.viewport = viewport
        for mesh, look in translucent:
            self._use_look(self.oit_program, look)
            self.pacer.draw(self._vaos_for(mesh)[2], mesh.n_triangles, mesh.first_triangle)
        self.ctx.disable_direct(GL_CLIP_DISTANCE0)   # the resolve's full-screen quad writes no clip distance
        self.oit.resolve(destination, viewport)

    @staticmethod
    def _use_look(program: moderngl.Program, look: SurfaceLook, back_color=None) -> None:
        program["u_front_color"].value = look.color
        program["u_origin"].value = look.origin
        if back_color is not None:   # opaque only: a translucent shell's inside takes its front colour
            program["u_back_color"].value = back_color
        if "u_opacity" in program:
            program["u_opacity"].value = look.opacity
        color_by = look.color_by
        program["u_color_source"].value = 0 if color_by is None else 1 if color_by.scalar_texture is None else 2
        if color_by is not None:
            color_by.lut_texture.use(COLORMAP_UNIT)
            program["u_scalar_range"].value = color_by.value_range
            if color_by.scalar_texture is not None:
                color_by.scalar_texture.use(SCALAR_UNIT)
                program["u_spacing"].value = color_by.spacing
                program["u_dims"].value = color_by.shape
                program["u_scalar_origin"].value = color_by.origin

    def release(self) -> None:
        """Free the renderer's GL objects: programs, vertex arrays, depth targets, the OIT targets, the slices and the
        ray caster."""
        self._release_vaos()
        if self._opaque is not None:
            self._opaque.release()
        if self._raycaster is not None:
            self._raycaster.release()
        self.oit.release()
        self.slices.release()
        for obj in (self.box_vao, self.box_buffer, self.mesh_program, self.wire_program, self.box_program,
                    self.oit_program):
            obj.release()


class DrawPacer:
    """Draws indexed triangles, waiting for the GL (`ctx.finish`) after every `every` triangles drawn, whatever
    the meshes they came in (0: never): on a software renderer what it holds for the draws not yet rasterized
    stays bounded (SOFTWARE_DRAW_TRIANGLES)."""

    def __init__(self, ctx: moderngl.Context, every: int):
        self.ctx, self.every = ctx, int(every)
        self.pending = 0   # triangles drawn since the last wait

    def draw(self, vao: moderngl.VertexArray, n_triangles: int, first_triangle: int = 0) -> None:
        """`n_triangles` of `vao`'s triangles from its `first_triangle`-th."""
        if self.every <= 0:
            vao.render(moderngl.TRIANGLES, vertices=3 * n_triangles, first=3 * first_triangle)
            return
        first = 0
        while first < n_triangles:
            count = min(n_triangles - first, self.every - self.pending)
            vao.render(moderngl.TRIANGLES, vertices=3 * count, first=3 * (first_triangle + first))
            first += count
            self.pending += count
            if self.pending >= self.every:
                self.ctx.finish()
                self.pending = 0


def read_rgb(framebuffer: moderngl.Framebuffer, size: tuple[int, int], components: int = 3) -> np.ndarray:
    """The framebuffer's pixels as an (height, width, components) uint8 array, top row first (as in a PNG)."""
    width, height = size
    data = framebuffer.read(viewport=(0, 0, width, height), components=components, alignment=1)
    return np.frombuffer(data, np.uint8).reshape(height, width, components)[::-1].copy()


class OffscreenTarget:
    """A multisampled colour+depth framebuffer for headless renders, resolved on read."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int], samples: int = 4):
        self.ctx = ctx
        self.size = size
        samples = min(samples, ctx.max_samples)
        self.multisampled = ctx.framebuffer(
            color_attachments=[ctx.renderbuffer(size, 4, samples=samples)],
            depth_attachment=ctx.depth_renderbuffer(size, samples=samples))
        self.resolved = ctx.framebuffer(color_attachments=[ctx.renderbuffer(size, 4)])

    @property
    def viewport(self) -> tuple[int, int, int, int]:
        """(x, y, width, height) of the whole target."""
        return (0, 0, *self.size)

    def use(self) -> None:
        """Draw into the multisampled framebuffer from here on."""
        self.multisampled.use()

    def read_rgb(self) -> np.ndarray:
        """Resolve the samples and read the pixels: (height, width, 3) uint8, top row first."""
        self.ctx.copy_framebuffer(self.resolved, self.multisampled)
        return read_rgb(self.resolved, self.size)

    def read_rgba(self) -> np.ndarray:
        """(height, width, 4) uint8, straight alpha, for a scene drawn over a transparent background."""
        self.ctx.copy_framebuffer(self.resolved, self.multisampled)
        rgba = read_rgb(self.resolved, self.size, components=4).astype(np.float32)
        alpha = rgba[:, :, 3:]
        rgba[:, :, :3] = np.where(alpha > 0, rgba[:, :, :3] * 255.0 / np.maximum(alpha, 1.0), 0.0)
        return np.clip(np.round(rgba), 0, 255).astype(np.uint8)

    def release(self) -> None:
        """Free both framebuffers and their attachments."""
        for framebuffer in (self.multisampled, self.resolved):
            for attachment in (*framebuffer.color_attachments, framebuffer.depth_attachment):
                if attachment is not None:
                    attachment.release()
            framebuffer.release()
