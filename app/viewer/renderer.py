"""Draws the scene: the lit isosurface, its wireframe overlay and the volume's bounding box.

The mesh is drawn straight from the extractor's GPU buffers (no read-back).
This module owns the scene's GL objects: programs, VAOs, the box's vertex
buffer, and the multisampled offscreen target used by headless renders.
"""
from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from ..resources import shader_source

# The extractor's 32-byte vertex record: vec4(position.xyz, value), vec4(normal.xyz, 0).
MESH_FORMAT = "3f 1x4 3f 1x4"
MESH_POSITION_ONLY_FORMAT = "3f 1x4 4x4"
WIRE_COLOR = (0.02, 0.02, 0.05)
WIRE_OPACITY = 0.45

# The 12 edges of a box as pairs of corner indices; corner i has bit k set when axis k is at `upper`.
_BOX_EDGES = [(a, b) for a in range(8) for b in range(8) if a < b and bin(a ^ b).count("1") == 1]


@dataclass
class SurfaceStyle:
    """How the surface looks: what the panel's toggles and colour pickers edit."""
    front_color: tuple[float, float, float] = (0.55, 0.70, 0.90)
    back_color: tuple[float, float, float] = (0.90, 0.45, 0.25)   # distinct, so holes/inside-out show
    background: tuple[float, float, float] = (0.11, 0.12, 0.14)
    box_color: tuple[float, float, float] = (0.65, 0.65, 0.65)
    lighting: bool = True
    wireframe: bool = False
    show_box: bool = True


class SceneRenderer:
    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        mesh_vert = shader_source("mesh.vert")
        self.mesh_program = ctx.program(vertex_shader=mesh_vert, fragment_shader=shader_source("mesh.frag"))
        self.wire_program = ctx.program(vertex_shader=mesh_vert, fragment_shader=shader_source("flat.frag"))
        self.box_program = ctx.program(vertex_shader=shader_source("box.vert"), fragment_shader=shader_source("flat.frag"))
        self.box_buffer = ctx.buffer(reserve=len(_BOX_EDGES) * 2 * 3 * 4)
        self.box_vao = ctx.vertex_array(self.box_program, [(self.box_buffer, "3f", "in_position")])
        self._mesh_vao = self._wire_vao = None
        self._bound_buffers: tuple[object, object] = (None, None)

    def set_box(self, lower, upper) -> None:
        """The bounding box to draw, in world units."""
        corners = np.array([[(upper if (i >> k) & 1 else lower)[k] for k in range(3)] for i in range(8)], "f4")
        self.box_buffer.write(corners[np.array(_BOX_EDGES).ravel()].tobytes())

    def _bind_mesh(self, mesh) -> None:
        # extract() may reallocate its buffers when the mesh grows: rebind only then.
        buffers = (mesh.vertex_buffer, mesh.index_buffer)
        if buffers[0] is self._bound_buffers[0] and buffers[1] is self._bound_buffers[1]:
            return
        self._release_mesh_vaos()
        vbo, ibo = buffers
        self._mesh_vao = self.ctx.vertex_array(
            self.mesh_program, [(vbo, MESH_FORMAT, "in_position", "in_normal")],
            index_buffer=ibo, index_element_size=4)
        self._wire_vao = self.ctx.vertex_array(
            self.wire_program, [(vbo, MESH_POSITION_ONLY_FORMAT, "in_position")],
            index_buffer=ibo, index_element_size=4)
        self._bound_buffers = buffers

    def _release_mesh_vaos(self) -> None:
        for vao in (self._mesh_vao, self._wire_vao):
            if vao is not None:
                vao.release()
        self._mesh_vao = self._wire_vao = None
        self._bound_buffers = (None, None)

    def draw(self, mesh, camera, viewport: tuple[int, int, int, int], style: SurfaceStyle,
             covered_left: int = 0) -> None:
        """Clear `viewport` of the bound framebuffer and draw the scene into it.

        `mesh` has the extractor's `vertex_buffer`, `index_buffer` and `n_triangles` (or is None).
        `covered_left`: pixels at the left hidden by the panel; the scene centres in the rest.
        """
        ctx = self.ctx
        # imgui's C++ renderer changes GL state behind moderngl's back: set all we rely on.
        ctx.viewport = viewport
        ctx.scissor = None
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<="
        ctx.wireframe = False
        ctx.polygon_offset = (0.0, 0.0)
        ctx.clear(*style.background, 1.0, depth=1.0, viewport=viewport)

        width, height = viewport[2], viewport[3]
        view = camera.view_matrix().tobytes()
        shift_x = min(max(covered_left, 0), width // 2) / max(width, 1)
        projection = camera.projection_matrix(width / max(height, 1), shift_x).tobytes()
        for program in (self.mesh_program, self.wire_program, self.box_program):
            program["u_view"].write(view)
            program["u_projection"].write(projection)

        if style.show_box:
            self.box_program["u_color"].value = style.box_color
            self.box_program["u_opacity"].value = 1.0
            self.box_vao.render(moderngl.LINES)

        if mesh is None or mesh.n_triangles == 0:
            return
        self._bind_mesh(mesh)
        n_indices = mesh.n_triangles * 3
        self.mesh_program["u_front_color"].value = style.front_color
        self.mesh_program["u_back_color"].value = style.back_color
        self.mesh_program["u_lighting"].value = style.lighting
        if style.wireframe:
            # Push the filled surface back a little so its own edges win the depth test.
            ctx.polygon_offset = (1.0, 1.0)
        self._mesh_vao.render(moderngl.TRIANGLES, vertices=n_indices)
        if style.wireframe:
            ctx.polygon_offset = (0.0, 0.0)
            ctx.wireframe = True
            # Translucent lines: a dense mesh still shows the shading underneath.
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
            self.wire_program["u_color"].value = WIRE_COLOR
            self.wire_program["u_opacity"].value = WIRE_OPACITY
            self._wire_vao.render(moderngl.TRIANGLES, vertices=n_indices)
            ctx.disable(moderngl.BLEND)
            ctx.wireframe = False

    def release(self) -> None:
        self._release_mesh_vaos()
        for obj in (self.box_vao, self.box_buffer, self.mesh_program, self.wire_program, self.box_program):
            obj.release()


def read_rgb(framebuffer: moderngl.Framebuffer, size: tuple[int, int]) -> np.ndarray:
    """The framebuffer's pixels as an (height, width, 3) uint8 array, top row first (as in a PNG)."""
    width, height = size
    data = framebuffer.read(viewport=(0, 0, width, height), components=3, alignment=1)
    return np.frombuffer(data, np.uint8).reshape(height, width, 3)[::-1].copy()


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
        return (0, 0, *self.size)

    def use(self) -> None:
        self.multisampled.use()

    def read_rgb(self) -> np.ndarray:
        self.ctx.copy_framebuffer(self.resolved, self.multisampled)
        return read_rgb(self.resolved, self.size)

    def release(self) -> None:
        for framebuffer in (self.multisampled, self.resolved):
            for attachment in (*framebuffer.color_attachments, framebuffer.depth_attachment):
                if attachment is not None:
                    attachment.release()
            framebuffer.release()
