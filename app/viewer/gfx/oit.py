"""Translucent surfaces by weighted blended order-independent transparency (McGuire & Bavoil 2013).

Why weighted blended OIT and not depth peeling: peeling draws every translucent triangle once
per layer, and two nested closed shells are four layers deep at the centre, so four or more
passes over all the translucent geometry.  On llvmpipe, where drawing triangles is what a frame
costs (130-250 ms per million, single-threaded vertex work), that is 4x the frame time while
dragging.  Weighted blended OIT draws each translucent triangle once, into two float targets,
plus one full-screen resolve.  Its one approximation, the mean colour of the layers at a pixel
weighted by depth instead of sorted, is exact wherever one translucent layer covers an opaque
surface (a translucent skin over an opaque brain, from any side) and close elsewhere.

A frame with translucent surfaces:
1. the opaque scene (box, opaque surfaces, wireframe) into `scene` (colour texture + depth);
2. translucent surfaces into `accum` (rgb: sum of w a c, a: product of 1 - a) and `weights`
   (sum of w a), depth-tested against the opaque depth but not writing it;
3. the resolve writes mean colour over the opaque scene into the caller's framebuffer.
The targets follow the caller's framebuffer's size and sample count (multisampled headless
renders resolve per sample).
"""
from __future__ import annotations

import moderngl

from .composite import CompositeTargets

# Additive for the weighted sums; the accum target's alpha multiplies by (1 - a): the revealage.
ACCUM_BLEND = (moderngl.ONE, moderngl.ONE, moderngl.ZERO, moderngl.ONE_MINUS_SRC_ALPHA)


class OitTargets(CompositeTargets):
    """The two float targets of weighted blended OIT and the program that composites them over the opaque scene, sized
    to the framebuffer being drawn."""

    def __init__(self, ctx: moderngl.Context):
        super().__init__(ctx, "oit_composite.frag", ("u_scene", "u_accum", "u_weights"))
        self.scene = self.accum = None

    def prepare(self, size: tuple[int, int], samples: int) -> None:
        """Targets of this size and sample count (made again only when either changes)."""
        if self._key == (size, samples):
            return
        self._release_targets()
        ctx = self.ctx
        colour, accum, weights = (ctx.texture(size, 4, dtype="f1", samples=samples),
                                  ctx.texture(size, 4, dtype="f2", samples=samples),
                                  ctx.texture(size, 1, dtype="f2", samples=samples))
        depth = ctx.depth_renderbuffer(size, samples=samples)
        self.textures = (colour, accum, weights)
        self.scene = ctx.framebuffer([colour], depth)
        self.accum = ctx.framebuffer([accum, weights], depth)
        self.accum.depth_mask = False   # translucent layers neither write depth nor clear it
        self._objects = [colour, accum, weights, depth, self.scene, self.accum]
        self._key = (size, samples)

    def begin_translucent(self) -> None:
        """Step 2's set-up, after the opaque scene is in `scene`."""
        self.accum.use()
        self.accum.clear(0.0, 0.0, 0.0, 1.0)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = ACCUM_BLEND

    def resolve(self, destination: moderngl.Framebuffer, viewport) -> None:
        """Step 3: the translucent layers over the opaque scene, into `destination`."""
        ctx = self.ctx
        destination.use()
        ctx.viewport = viewport
        ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST)
        self._composite(self.textures, self._key[1] > 0)
        ctx.enable(moderngl.DEPTH_TEST)
