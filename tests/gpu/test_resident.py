"""The resident volume shared by composition: who owns which GL object, and what each part takes.

One `ResidentVolume` owns the volume image, the brick ranges, the grid uniforms and the value range;
extractors of each cell kind, smoothing and sharp features take it; each owner releases every GL
object it made; a `GpuMesh` says by its type whether its holder frees its buffers."""
from __future__ import annotations

import moderngl
import numpy as np
import pytest
from support.mesh_checks import assert_same_mesh
from support.sdf_boxes import Box, grid_points

from isoscope.cpu.cubes import marching_cubes_reference
from isoscope.cpu.tetra import marching_tetrahedra_reference
from isoscope.gpu.buffers import GROWTH, GrowableBuffer
from isoscope.gpu.cubes import CUBES, Extractor
from isoscope.gpu.extraction import SurfaceExtractor
from isoscope.gpu.limits import GpuLimits
from isoscope.gpu.mesh import GpuMesh, OwnedMesh
from isoscope.gpu.programs import timer_queries
from isoscope.gpu.resident import ResidentVolume
from isoscope.gpu.sharp import SharpExtractor
from isoscope.gpu.smooth import Smoother
from isoscope.gpu.tetra import TETRAHEDRA, TetraExtractor

RNG = np.random.default_rng(20261202)
GL_TYPES = (moderngl.Buffer, moderngl.Texture, moderngl.Texture3D)


def gl_objects(owner, borrowed=()) -> list:
    """Every buffer and texture reachable from `owner`'s attributes (through isoscope objects and
    containers), not through `borrowed` objects.  Compiled programs and timer queries are the
    context's (programs.py) and not counted."""
    found, seen = [], {id(b) for b in borrowed}

    def walk(value):
        if value is None or id(value) in seen:
            return
        seen.add(id(value))
        if isinstance(value, GL_TYPES):
            found.append(value)
        elif isinstance(value, (list, tuple)):
            for item in value:
                walk(item)
        elif isinstance(value, dict):
            for item in value.values():
                walk(item)
        elif type(value).__module__.startswith("isoscope.") and hasattr(value, "__dict__"):
            for item in vars(value).values():
                walk(item)
    walk(owner)
    return found


def released(objects) -> bool:
    return all(isinstance(obj.mglo, moderngl.InvalidObject) for obj in objects)


def noise(shape=(24, 25, 33)):
    return RNG.normal(size=shape).astype(np.float32)


def small_blocks(ctx, kib=64):
    real = GpuLimits.of(ctx)
    return GpuLimits(real.max_3d_texture_size, real.max_texture_size, kib << 10)


def test_releasing_an_extractor_releases_every_gl_object_it_owns(gl_ctx):
    # Small storage blocks: the mesh is written in windows and the per-run brick list is made too.
    volume = noise()
    cubes = Extractor(volume, ctx=gl_ctx, limits=small_blocks(gl_ctx))
    tetra = TetraExtractor(cubes)
    cubes.extract(0.1)
    tetra.extract(0.1)
    assert cubes.scratch.run_list is not None and tetra.scratch.run_list is not None
    resident = gl_objects(cubes.resident)
    own_cubes, own_tetra = gl_objects(cubes, borrowed=[cubes.resident]), gl_objects(tetra, borrowed=[cubes.resident])
    assert cubes.resident.texture in resident and cubes.resident.brick_ranges in resident
    assert len(own_tetra) >= 12 and not set(map(id, own_tetra)) & set(map(id, own_cubes + resident))
    tetra.release()
    assert released(own_tetra) and not released(resident) and not released(own_cubes)
    cubes.extract(0.2)  # the tetrahedra took nothing of the cubes' with them
    assert_same_mesh(cubes.read_mesh(), marching_cubes_reference(volume, 0.2))
    cubes.release()
    assert released(own_cubes) and released(resident) and cubes.gpu_bytes() == 0
    cubes.release()  # twice is fine
    tetra.release()


def test_smoothing_and_sharp_features_release_what_they_made_and_nothing_of_the_volume(gl_ctx):
    with Extractor(noise(), ctx=gl_ctx) as cubes:
        cubes.extract(0.1)
        smoother, sharp = Smoother(cubes.resident), SharpExtractor(cubes.resident)
        smoother.smooth(cubes.mesh, 2, level=0.1)
        assert sharp.may_bend(30.0, cubes.mesh) in (True, False)
        made = gl_objects(smoother, borrowed=[cubes.resident]) + gl_objects(sharp, borrowed=[cubes.resident])
        assert len(made) >= 8
        smoother.release()
        sharp.release()
        assert released(made) and not released(gl_objects(cubes.resident))


def test_the_tetrahedra_have_no_set_up_of_their_own_nor_what_needs_it(gl_ctx):
    # Composition: both kinds are SurfaceExtractors on a ResidentVolume; only the maker of the volume
    # (the cubes Extractor) can reload it or ask whether a volume fits.
    assert not issubclass(TetraExtractor, Extractor) and issubclass(TetraExtractor, SurfaceExtractor)
    for name in ("reload", "fits", "_measure", "_value_range", "_volume"):
        assert not hasattr(TetraExtractor, name), name
    assert (CUBES.job_components, TETRAHEDRA.job_components) == (1, 2)
    with Extractor(noise(), ctx=gl_ctx) as cubes, TetraExtractor(cubes) as tetra:
        assert tetra.resident is cubes.resident and tetra.plan is cubes.plan
        assert tetra.value_range == cubes.value_range and tetra.kind is TETRAHEDRA


def test_one_resident_volume_serves_both_kinds_smoothing_and_a_reload(gl_ctx):
    volume, other = noise(), noise()
    with ResidentVolume(volume, ctx=gl_ctx) as resident:
        cubes, tetra = SurfaceExtractor(resident, CUBES), SurfaceExtractor(resident, TETRAHEDRA)
        try:
            cubes.extract(0.3)
            tetra.extract(0.3)
            assert_same_mesh(cubes.read_mesh(), marching_cubes_reference(volume, 0.3))
            assert_same_mesh(tetra.read_mesh(), marching_tetrahedra_reference(volume, 0.3))
            assert resident.fits(other) and not resident.fits(other[:-1]) and not resident.fits(other.astype(np.uint8))
            resident.reload(other, spacing=(1.0, 2.0, 1.0))
            tetra.extract(0.3)  # reads the new samples, ranges and spacing
            assert_same_mesh(tetra.read_mesh(), marching_tetrahedra_reference(other, 0.3, (1.0, 2.0, 1.0)))
            with pytest.raises(ValueError, match="does not fit"):
                resident.reload(other[:-1])
            smoother = Smoother(resident)
            try:
                with pytest.raises(ValueError, match="needs a level"):
                    smoother.smooth(cubes.mesh, 1)  # a resident volume has no last level: say which
            finally:
                smoother.release()
        finally:
            cubes.release()
            tetra.release()
    assert resident.texture is None and resident.gpu_bytes() == 0


def test_extractors_share_the_contexts_timer_queries(gl_ctx):
    # moderngl cannot delete a query: the context keeps one pair, rather than each extractor leaking two.
    with Extractor(noise(), ctx=gl_ctx) as a, Extractor(noise(), ctx=gl_ctx) as b:
        assert a._timers is b._timers is timer_queries(gl_ctx)


def test_who_frees_a_mesh_is_said_by_its_type(gl_ctx):
    with Extractor(noise(), ctx=gl_ctx) as ex:
        ex.extract(0.1)
        view = ex.mesh
        assert type(view) is GpuMesh and not hasattr(view, "release")  # the extractor's buffers
        uploaded = GpuMesh.upload(gl_ctx, *ex.read_mesh())
        assert isinstance(uploaded, OwnedMesh) and isinstance(uploaded, GpuMesh)
        for a, b in zip(uploaded.read(), ex.read_mesh()):
            np.testing.assert_array_equal(a, b)
        uploaded.release()
        assert released([uploaded.vertex_buffer, uploaded.index_buffer]) and not released([ex.vertex_buffer])


def test_a_sharpened_mesh_releases_its_upload_and_never_the_extractors_buffers(gl_ctx):
    from isoscope.gpu.sharp_features import SharpenedMesh
    box = -Box([11.3, 12.4, 11.6], [6.2, 4.7, 5.4]).sdf(grid_points(24)).astype(np.float32)
    ball = (10.5 - np.linalg.norm(grid_points(24) - 11.7, axis=-1)).astype(np.float32)
    with Extractor(box, ctx=gl_ctx) as ex:
        ex.extract(0.0)
        shown = SharpenedMesh(gl_ctx)
        try:
            shown.take(ex, box, 30.0)
            upload = shown.mesh
            assert isinstance(upload, OwnedMesh)  # a box has features: their mesh was uploaded
            with Extractor(ball, ctx=gl_ctx) as round_one:  # no feature: the extractor's mesh is shown
                round_one.extract(0.0)
                shown.take(round_one, ball, 30.0)
                assert released([upload.vertex_buffer, upload.index_buffer])
                assert type(shown.mesh) is GpuMesh and shown.mesh.vertex_buffer is round_one.vertex_buffer
                shown.release()
                assert not released([round_one.vertex_buffer, round_one.index_buffer])  # not the step's to free
        finally:
            shown.release()


def test_a_growable_buffer_grows_by_half_and_keeps_its_size_for_less(gl_ctx):
    buffer = GrowableBuffer(gl_ctx, minimum=16)
    try:
        assert buffer.size == 16
        first = buffer.ensure(100)
        assert buffer.size == 100 and buffer.ensure(40) is first  # less: the same buffer
        buffer.ensure(120)
        assert buffer.size == int(100 * GROWTH) and released([first])
        assert buffer.write(b"abcd").read(4) == b"abcd"
    finally:
        buffer.release()
    assert buffer.buffer is None and buffer.size == 0
    buffer.release()
