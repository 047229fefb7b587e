"""Offscreen targets copied or resolved into the framebuffer drawn by one full-screen triangle, per sample
where they are multisampled: what weighted blended OIT (oit.py) and the opaque scene drawn once for the rays
(opaque_pass.py) share: the composite programs with and without MULTISAMPLE, and the targets' lifetime."""
from __future__ import annotations

import moderngl

from ...resources import shader_source


class CompositeTargets:
    """A composite program per sample kind (shaders/NAME, MULTISAMPLE defined or not), its texture units named
    in order, and the targets (`_objects`, made for `_key`) that subclasses make."""

    def __init__(self, ctx: moderngl.Context, fragment: str, units: tuple[str, ...]):
        self.ctx = ctx
        self.programs = {multisampled: ctx.program(
            vertex_shader=shader_source("oit_composite.vert"),
            fragment_shader=shader_source(fragment, {"MULTISAMPLE": 1} if multisampled else None))
            for multisampled in (False, True)}
        for program in self.programs.values():
            for unit, name in enumerate(units):
                program[name].value = unit
        self.vaos = {key: ctx.vertex_array(program, []) for key, program in self.programs.items()}
        self._key = None
        self._objects: list = []

    def _composite(self, textures, multisampled: bool) -> None:
        """The full-screen triangle into the bound framebuffer, `textures` on the units in order."""
        for unit, texture in enumerate(textures):
            texture.use(unit)
        self.vaos[multisampled].render(moderngl.TRIANGLES, vertices=3)

    def _release_targets(self) -> None:
        for obj in self._objects:
            obj.release()
        self._objects, self._key = [], None

    def release(self) -> None:
        """Free the targets and the composite programs."""
        self._release_targets()
        for obj in (*self.vaos.values(), *self.programs.values()):
            obj.release()
