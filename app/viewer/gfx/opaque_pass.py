"""The opaque scene drawn once where the rays need its depth (gfx/raycast.py: slices and opaque surfaces end
the rays): into a target of its own, colour and depth textures at the sample count of the framebuffer
being drawn, then copied into that framebuffer whole (colour and depth) and its depth handed to the rays
(multisampled, they read its first sample: no resolve).  Before it, the meshes were drawn twice a frame: on
screen, and again into a depth texture for the rays.

A frame with rays and something opaque:
1. `begin`: the target bound; the caller clears it and draws the box, the slices and the opaque meshes;
2. `finish`: the target copied into the framebuffer bound before `begin`, that bound again, and its depth
   for the rays returned.  The copy is a blit where that framebuffer is one of ours alike (a
   render's multisampled target, the OIT scene: a few ms at 1280x800x4 on llvmpipe), else (the window's
   own framebuffer, whose depth format GL does not tell) a full-screen pass writing colour and depth,
   sample by sample (shaders/opaque_composite.frag: ~50 ms there).
"""
from __future__ import annotations

import moderngl

from .composite import CompositeTargets
from .raycast import SceneDepth


class OpaquePass(CompositeTargets):
    """The opaque scene's own target (colour + depth textures), its copy into the framebuffer drawn, and its
    depth for the rays."""

    def __init__(self, ctx: moderngl.Context):
        super().__init__(ctx, "opaque_composite.frag", ("u_colour", "u_depth"))
        self._target = self._colour = self._depth = None
        self._destination = None
        self._blit = False

    def _prepare(self, size: tuple[int, int], samples: int) -> None:
        """Targets of this size and sample count (made again only when either changes)."""
        if self._key == (size, samples):
            return
        self._release_targets()
        ctx = self.ctx
        self._colour = ctx.texture(size, 4, samples=samples)
        self._depth = ctx.depth_texture(size, samples=samples)
        self._target = ctx.framebuffer([self._colour], self._depth)
        self._objects = [self._colour, self._depth, self._target]
        if not samples:   # (a multisample texture has no sampler state)
            self._depth.compare_func = ""   # read as they are (texelFetch), not compared
        self._key = (size, samples)

    def begin(self, viewport) -> None:
        """Bind the target (the size of the framebuffer bound now, up to `viewport`'s far corner, and its sample
        count) for the opaque scene, clear and box included; `finish` copies it back."""
        destination = self._destination = self.ctx.fbo
        size = (viewport[0] + viewport[2], viewport[1] + viewport[3])
        self._prepare(size, destination.samples)
        self._blit = self.blits_into(destination, size, viewport)
        self._target.use()
        self.ctx.viewport = viewport

    @staticmethod
    def blits_into(destination, size, viewport) -> bool:
        """Whether the target can be blitted into `destination` whole: one of ours alike (one colour attachment
        and a depth one, the same size, the viewport all of it), not the window's own framebuffer."""
        return (len(getattr(destination, "color_attachments", None) or ()) == 1   # the window's: None
                and getattr(destination, "depth_attachment", None) is not None
                and tuple(destination.size) == tuple(size) and tuple(viewport[:2]) == (0, 0))

    def finish(self, viewport) -> SceneDepth:
        """What was drawn since `begin` copied into the framebuffer bound before it, that bound again; its depth
        (a texture from (0, 0)) where the rays end."""
        ctx = self.ctx
        multisampled = self._key[1] > 0
        if self._blit:
            ctx.copy_framebuffer(self._destination, self._target)
            self._destination.use()
        else:
            self._destination.use()
            ctx.viewport = viewport
            ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST)
            ctx.depth_func = "1"   # always: written whatever it held
            ctx.enable(moderngl.DEPTH_TEST)
            self._composite((self._colour, self._depth), multisampled)
            ctx.depth_func = "<="
        ctx.viewport = viewport
        self._destination = None
        return SceneDepth(self._depth, multisampled=multisampled)
