"""Volumes at and past the GL limits the extractor depends on: the 3-D texture size, and the
row padding it does itself (4 samples per RGBA texel along axis 2)."""
import numpy as np
import pytest

import isoscope.extractor as extractor_module
from isoscope.extractor import Extractor, GPULimitError
from isoscope.reference import marching_cubes_reference
from mesh_checks import assert_same_mesh

RNG = np.random.default_rng(7)


def texture_limit(ctx) -> int:
    return int(ctx.info["GL_MAX_3D_TEXTURE_SIZE"])


def test_rows_padded_to_whole_texels_go_up_in_slabs(gpu_mesh, monkeypatch):
    # 13 samples per row are padded to 16; a 1-byte slab budget forces one upload per plane.
    monkeypatch.setattr(extractor_module, "UPLOAD_SLAB_BYTES", 1)
    volume = RNG.normal(size=(5, 7, 13)).astype(np.float32)
    assert_same_mesh(gpu_mesh(volume, 0.1), marching_cubes_reference(volume, 0.1))


def test_axis_2_may_be_four_times_the_texture_limit(gl_ctx, gpu_mesh):
    n2 = texture_limit(gl_ctx) + 5  # more samples than one texture axis holds, padded to whole texels
    volume = RNG.normal(size=(2, 3, n2)).astype(np.float32)
    assert_same_mesh(gpu_mesh(volume, 0.0), marching_cubes_reference(volume, 0.0))


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_volume_past_the_texture_limit_is_refused_with_the_fix(gl_ctx, axis):
    shape = [2, 2, 2]
    shape[axis] = texture_limit(gl_ctx) * (4 if axis == 2 else 1) + 1
    volume = np.zeros(shape, np.float32)
    with pytest.raises(GPULimitError) as caught:
        Extractor(volume, ctx=gl_ctx)
    message = str(caught.value)
    assert "\n" not in message
    assert "x".join(map(str, shape)) in message and "3-D texture limit" in message
    assert "downsample" in message
