"""The volume resident on the GPU, shared by every pass that reads it.

    >>> volume = ResidentVolume(array, spacing=(1, 1, 1), gradient_direction="descent")
    >>> cubes = SurfaceExtractor(volume, CUBES)       # each extractor holds its own scratch and mesh
    >>> tetra = SurfaceExtractor(volume, TETRAHEDRA)  # on the same image and brick ranges
    >>> Smoother(volume), SharpExtractor(volume)      # smoothing and sharp features read it too

One object owns what is the same at every level and for every kind of cell: the volume image
(RGBA texels of 4 axis-2 samples: volume_texture.py), each brick's value range (for empty-space
skipping: measured once per volume by `mc_row_range` and `mc_brick_range`), the grid uniforms every
pass of mc_common.glsl is told, the sample format's #defines and the value range.  Whoever made it
releases it, after the extractors, smoothers and sharp-feature passes that use it.

Scratch: 8 bytes per brick for the ranges (and, while they are measured, 8 per 32-sample word
for the row ranges, released at once).
"""
from __future__ import annotations

import moderngl
import numpy as np

from .. import validation
from ..core.layout import GROUP_SIZE, ImageUnit, StorageBlock, divisor_magic, job_coordinate_bits, volume_texel_format
from ..errors import InputError
from .context import current_or_standalone
from .limits import GpuLimits, plan_extractor
from .programs import compute_program, dispatch_groups, set_uniforms
from .volume_texture import upload_volume, write_volume

__all__ = ["ResidentVolume", "resident_of"]

RANGE_PASSES = ("mc_row_range", "mc_brick_range")


class ResidentVolume:
    """A volume on the GPU: its image, brick ranges, grid uniforms and value range.

    `volume` is an array, or a `validation.CheckedVolume`, which is taken without scanning it again.
    Every size limit is checked before anything is allocated (`plan`), and whatever was allocated is
    released if a later step fails.  `limits` overrides the GL implementation's limits (tests lower
    them to reach the refusals)."""

    def __init__(self, volume, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                 ctx: moderngl.Context | None = None, limits: GpuLimits | None = None):
        checked = validation.check_volume(volume)
        self.ctx = ctx or current_or_standalone()
        self.shape = checked.samples.shape
        self.plan = plan_extractor(self.shape, limits or GpuLimits.of(self.ctx))  # refuses before allocating
        self.texel_format = volume_texel_format(checked.samples.dtype)
        _, volume_format, volume_image = self.texel_format
        self.defines = {"VOLUME_FORMAT": volume_format, "VOLUME_IMAGE": volume_image}
        """What a program that reads the image must be compiled with (its sample format)."""
        self.job_bits = job_coordinate_bits(self.shape)
        """(bits of j, bits of k) when a cubes vertex job can hold its sample's coordinates, else None."""
        self._take(checked, spacing, gradient_direction)
        self._range_passes = {name: compute_program(self.ctx, f"{name}.comp", self.defines) for name in RANGE_PASSES}
        self.texture: moderngl.Texture3D | None = None
        self.brick_ranges: moderngl.Buffer | None = None
        self._non_finite: moderngl.Buffer | None = None
        try:
            self.texture = upload_volume(self.ctx, checked.samples, self.plan)  # any order: slabs, no copy
            self.brick_ranges = self._storage(self.plan.storage_elements()["brick ranges"])
            self._non_finite = self._storage(1)  # set by mc_row_range.comp: a NaN or infinite sample
            self._measure(checked)
        except BaseException:
            self.release()
            raise

    def _storage(self, elements: int) -> moderngl.Buffer:
        """A work buffer; plan_extractor has already checked its size against the limit."""
        return self.ctx.buffer(reserve=max(elements, 1) * 4)

    def _take(self, checked, spacing, gradient_direction) -> None:
        """The settings of a new volume: spacing, side, value range (as far as known) and grid uniforms."""
        self.spacing = validation.as_spacing(spacing)
        self.descent = validation.as_gradient_direction(gradient_direction)
        self.value_range = checked.value_range
        plan = self.plan
        # What every pass is told about the grid, the same at every level (the division constants too).
        self._grid_uniforms = dict(
            u_dims=self.shape, u_words=plan.words_per_row, u_bricks=plan.bricks,
            u_brick_count=plan.brick_count, u_spacing=self.spacing, u_word_shift=plan.word_shift,
            u_div_words=divisor_magic(plan.words_per_row), u_div_rows=divisor_magic(self.shape[1]),
            u_div_bricks_j=divisor_magic(plan.bricks[1]))
        if self.job_bits is not None:
            self._grid_uniforms["u_job_bits"] = self.job_bits

    # -- what the passes on it read ----------------------------------------------------------

    @property
    def grid_uniforms(self) -> dict:
        """The grid uniforms of mc_common.glsl (not the level), for passes that include it."""
        return dict(self._grid_uniforms)

    @property
    def sign(self) -> float:
        """1 where the inside is below the level (descent), -1 where above: passes compare sign * value."""
        return 1.0 if self.descent else -1.0

    @property
    def brick_count(self) -> int:
        return self.plan.brick_count

    def bind(self) -> None:
        """The image, read-only, at its unit (ImageUnit.VOLUME)."""
        self.texture.bind_to_image(ImageUnit.VOLUME, read=True, write=False)

    # -- a new volume of the same kind ---------------------------------------------------------

    def fits(self, volume) -> bool:
        """Whether `reload` can take `volume` (an array or a CheckedVolume): the same shape, and samples
        the volume image holds in the same format."""
        data = volume.samples if isinstance(volume, validation.CheckedVolume) else np.asarray(volume)
        return data.shape == self.shape and volume_texel_format(data.dtype) == self.texel_format

    def reload(self, volume, spacing=(1.0, 1.0, 1.0), gradient_direction="descent") -> None:
        """Take a new volume of the same shape and sample format (`fits`): the image is written in place
        and the brick ranges measured again, nothing is allocated (new storage costs llvmpipe a zeroing
        pass and the OS a page fault per page).  A volume that does not fit raises ValueError and changes
        nothing."""
        checked = validation.check_volume(volume)
        validation.as_spacing(spacing)  # every argument checked before anything changes
        validation.as_gradient_direction(gradient_direction)
        if not self.fits(checked):
            raise InputError(f"a {checked.samples.dtype} volume of shape {checked.samples.shape} does not fit this "
                             f"extractor's {self.plan.dims_text} image; make a new Extractor for it")
        self._take(checked, spacing, gradient_direction)
        write_volume(self.texture, checked.samples, self.plan)
        self._measure(checked)

    def _measure(self, checked) -> None:
        """Each brick's value range, via each word's row range (a buffer freed afterwards); then the
        value range, where the volume's values were not scanned."""
        word_count = self.plan.word_count
        for program in self._range_passes.values():
            set_uniforms(program, **self._grid_uniforms, u_level=0.0, u_sign=self.sign)
        set_uniforms(self._range_passes["mc_row_range"], u_word_count=word_count)
        self.bind()
        row_ranges = self.ctx.buffer(reserve=self.plan.storage_elements()["row ranges"] * 4)
        self._non_finite.clear()
        try:
            row_ranges.bind_to_storage_buffer(StorageBlock.ROW_RANGES)
            self.brick_ranges.bind_to_storage_buffer(StorageBlock.BRICK_RANGES)
            self._non_finite.bind_to_storage_buffer(StorageBlock.NON_FINITE)
            dispatch_groups(self._range_passes["mc_row_range"], -(-word_count // GROUP_SIZE))
            self.ctx.memory_barrier()
            dispatch_groups(self._range_passes["mc_brick_range"], -(-self.brick_count // GROUP_SIZE))
            self.ctx.memory_barrier()
        finally:
            row_ranges.release()
        self.value_range = self._value_range(checked)

    def _value_range(self, checked) -> tuple[float, float]:
        """`checked`'s value range: its own, or for a volume whose values were not scanned
        (validation.check_volume(scan_values=False)) the brick ranges' union, after the row-range
        pass found no NaN or infinite sample; where it found one, check_volume's error."""
        if checked.value_range is not None:
            return checked.value_range
        if np.frombuffer(self._non_finite.read(4), np.uint32)[0]:
            checked = validation.check_volume(checked.samples)  # raises, naming the first bad sample
            return checked.value_range
        ranges = np.frombuffer(self.brick_ranges.read(8 * self.brick_count), np.float32).reshape(-1, 2)
        return float(ranges[:, 0].min()), float(ranges[:, 1].max())

    # -- memory ----------------------------------------------------------------------------------

    def image_bytes(self) -> int:
        """The volume image's size (0 once released)."""
        image = self.texture
        if image is None:
            return 0
        return image.width * image.height * image.depth * image.components * int(image.dtype[1:])

    def scratch_bytes(self) -> int:
        """The brick ranges and the non-finite flag."""
        return sum(b.size for b in (self.brick_ranges, self._non_finite) if b is not None)

    def gpu_bytes(self) -> int:
        return self.image_bytes() + self.scratch_bytes()

    def release(self) -> None:
        """Free the image and the work buffers; safe to call twice, or on a half-built one."""
        for obj in (self.texture, self.brick_ranges, self._non_finite):
            if obj is not None:
                obj.release()
        self.texture = self.brick_ranges = self._non_finite = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


def resident_of(source) -> ResidentVolume:
    """`source` itself if a ResidentVolume, else the resident volume `source` (an extractor) extracts from."""
    return source if isinstance(source, ResidentVolume) else source.resident
