"""Volumes as users have them, read in place: nibabel's Fortran order, 8- and 16-bit scans, float64, big-endian
files, negative and wide strides, memory maps.  Every one gives the mesh of the C-ordered float32 copy, bit for
bit (the numpy reference on that copy is the independent fact), with no copy of the volume made, and its value
range measured in the extractor's first pass is numpy's."""
from __future__ import annotations

import subprocess
import sys
import tracemalloc

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter
from support.command import NO_GL

import isoscope
from isoscope.api import marching_tetrahedra, outward_marching_cubes
from isoscope.cpu.compiled import CompiledCubes
from isoscope.cpu.cubes import marching_cubes_reference
from isoscope.cpu.extractor import CpuExtractor
from isoscope.cpu.samples import ORDER_C, ORDER_F, ORDER_STRIDED, sample_view
from isoscope.cpu.tetra import marching_tetrahedra_reference

TYPES = ("uint8", "int8", "uint16", "int16", "float32", "float64", ">u2", ">i2", ">f4", ">f8", "int32")


def scan(dtype: str, shape=(23, 30, 41)) -> np.ndarray:
    """A smooth random field over most of the type's range (integers) or in CT-like units (floats), C order."""
    field = gaussian_filter(np.random.default_rng(7).normal(size=shape), 2.0)
    field /= np.abs(field).max()
    kind = np.dtype(dtype)
    if kind.kind in "ui":
        info = np.iinfo(kind)
        field = np.clip(np.rint(field * (int(info.max) - int(info.min)) * 0.45 + (int(info.max) + int(info.min)) / 2),
                        info.min, info.max)
    else:
        field = field * 1000.0 + 1.0 / 3.0   # float64 values that float32 rounds
    return field.astype(kind)


def layouts(volume: np.ndarray) -> dict[str, np.ndarray]:
    """The same samples in the layouts users' arrays come in."""
    wide = np.zeros((volume.shape[0], volume.shape[1], volume.shape[2] * 3), volume.dtype)
    wide[:, :, ::3] = volume
    return {
        "C": volume,
        "Fortran (nibabel)": np.asfortranarray(volume),
        "reversed axes 0 and 2 (negative strides)": np.ascontiguousarray(volume[::-1, :, ::-1])[::-1, :, ::-1],
        "Fortran, axis 1 reversed": np.asfortranarray(volume[:, ::-1])[:, ::-1],
        "every third sample along axis 2": wide[:, :, ::3],
        "transposed twice": np.ascontiguousarray(volume.transpose(2, 0, 1)).transpose(1, 2, 0),
    }


def level_of(volume) -> float:
    return float(np.median(volume.astype(np.float64))) + 0.25


def assert_identical(got, want):
    for name, a, b in zip(("verts", "faces", "normals", "values"), got, want):
        assert a.dtype == b.dtype and a.shape == b.shape, name
        np.testing.assert_array_equal(a, b, err_msg=name)


@pytest.mark.parametrize("dtype", TYPES)
def test_every_type_and_layout_gives_the_float32_copy_s_mesh(dtype):
    volume = scan(dtype)
    copy = np.ascontiguousarray(volume, dtype=np.float32)
    level = level_of(volume)
    want = marching_cubes_reference(copy, level, (0.5, 1.0, 2.0), True)
    want_ascent = marching_cubes_reference(copy, level, (0.5, 1.0, 2.0), False)
    assert len(want[1]) > 1000
    for name, layout in layouts(volume).items():
        assert np.array_equal(layout, volume), name
        assert_identical(outward_marching_cubes(layout, level, spacing=(0.5, 1.0, 2.0), backend="cpu"), want)
        assert_identical(outward_marching_cubes(layout, level, spacing=(0.5, 1.0, 2.0), backend="cpu",
                                                gradient_direction="ascent"), want_ascent)


@pytest.mark.parametrize("dtype", ["uint8", "int16", ">i2", "float64"])
def test_scikit_image_s_call_and_tetrahedra_in_place(dtype):
    """marching_cubes (scikit-image's winding and values, made as the vertices are), step_size 2 (a strided
    view), and marching tetrahedra, on each layout: the numpy backend's arrays on the C float32 copy."""
    volume = scan(dtype)
    copy = np.ascontiguousarray(volume, dtype=np.float32)
    level = level_of(volume)
    for options in ({}, {"step_size": 2, "gradient_direction": "ascent"}):
        want = isoscope.marching_cubes(copy, level, backend="numpy", **options)
        for layout in layouts(volume).values():
            got = isoscope.marching_cubes(layout, level, backend="cpu", **options)
            assert_identical(got, want)
    tetrahedra = marching_tetrahedra_reference(copy, level, (1.0, 1.0, 1.0), True)
    for layout in layouts(volume).values():
        assert_identical(marching_tetrahedra(layout, level, backend="cpu"), tetrahedra)


@pytest.mark.parametrize("dtype", ["uint8", "int16", "float32", ">f8"])
def test_a_resident_extractor_reads_the_volume_where_it_lies(dtype):
    """Extractor(backend="cpu") keeps the user's array (no float32 copy) and gives the copy's mesh at each level,
    the second level through the words' ranges (an iso change reads only the words it cuts)."""
    volume = scan(dtype)
    copy = np.ascontiguousarray(volume, dtype=np.float32)
    levels = (level_of(volume), float(np.percentile(copy, 30)))
    for name, layout in layouts(volume).items():
        with isoscope.Extractor(layout, backend="cpu") as extractor:
            assert isinstance(extractor, CpuExtractor)
            assert np.shares_memory(extractor._compiled.view.flat, layout), name
            for level in levels:
                extractor.extract(level)
                assert_identical(extractor.read_mesh(), marching_cubes_reference(copy, level, (1, 1, 1), True))


@pytest.mark.parametrize("dtype", ["uint8", "int16", ">f8"])
def test_iso_changes_recount_only_the_changes_yet_match_a_fresh_extraction(dtype):
    """From the third level on, pass 2 counts again only the words next to a word whose bits changed and keeps
    the rest: on every layout, in both directions, over levels in small steps, repeated, on sample values and
    in big jumps, with the planes split differently between the threads each time, the mesh and every
    word's counts, edges, offsets and pass 4's plane shares are those of a fresh extraction at that level."""
    volume = scan(dtype)
    copy = volume.astype(np.float64)
    rng = np.random.default_rng(34)
    values = np.unique(copy)
    middle = float(np.median(copy))
    step = 1.0 if volume.dtype.kind in "ui" else 0.5
    levels = [middle, middle + step, middle, middle + step, middle + step, float(values[len(values) // 3]),
              float(values[len(values) // 3]) + step / 2, float(values[-2]), middle - 3 * step]
    levels += [float(rng.choice(values)) + float(rng.choice([0.0, 0.5, -step])) for _ in range(4)]
    levels = [min(max(level, values[0]), values[-1]) for level in levels]
    for descent in (True, False):
        for name, layout in layouts(volume).items():
            cubes = CompiledCubes(layout, (0.5, 1.0, 2.0), descent)
            for n, level in enumerate(levels):
                cubes.runs = int(rng.integers(1, 9))
                got = cubes.extract(level)
                fresh = CompiledCubes(layout, (0.5, 1.0, 2.0), descent)
                assert_identical(got, fresh.extract(level))
                for part in ("_edges", "_busy", "_plane_work"):
                    assert np.array_equal(getattr(cubes, part), getattr(fresh, part)), (name, level, part)
                for part in ("_vertex_offsets", "_triangle_offsets"):  # the offsets pass 4 reads: busy words'
                    assert np.array_equal(getattr(cubes, part)[fresh._busy], getattr(fresh, part)[fresh._busy])
                assert cubes._counted == (n >= 1), name  # the counts kept from the second level on


def test_rows_of_more_than_62_words_count_every_word_at_each_level():
    """A row of 63 words (2,016 samples along axis 2) has no room in a row's bit mask of changes: every level
    counts all words, and gives the fresh mesh."""
    volume = scan("float32", shape=(4, 5, 2016))
    cubes = CompiledCubes(volume, (1, 1, 1), True)
    for level in (0.0, 30.0, 0.0, -50.0):
        assert_identical(cubes.extract(level), CompiledCubes(volume, (1, 1, 1), True).extract(level))
        assert cubes._vertex_counts is cubes._vertex_offsets and not cubes._counted


def test_the_view_finds_the_memory_order():
    volume = scan("int16")
    assert sample_view(volume).order == ORDER_C
    assert sample_view(np.asfortranarray(volume)).order == ORDER_F
    assert sample_view(np.asfortranarray(volume)[:, ::-1]).order == ORDER_F
    assert sample_view(layouts(volume)["transposed twice"]).order == ORDER_STRIDED
    big_endian = sample_view(volume.astype(">i2"))
    assert big_endian.swap and big_endian.flat.dtype == np.int16 and np.shares_memory(big_endian.flat, volume) is False
    assert not sample_view(volume.astype(np.uint8)).swap   # one byte has no order


@pytest.mark.parametrize("dtype", ["uint8", "int8", "uint16", "int16", "float32", "float64", ">i2", ">f8"])
def test_the_first_pass_measures_numpy_s_value_range(dtype):
    volume = scan(dtype)
    want = (float(volume.min()), float(volume.max()))
    for name, layout in layouts(volume).items():
        cubes = CompiledCubes(layout, (1, 1, 1), True)
        cubes.extract(level_of(volume))
        assert cubes.value_range == want, name


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_sample_is_found_in_any_order(bad):
    """The range is measured in pass 1; a NaN or infinite sample there stops the call with check_volume's own
    line, the same for every layout as for the C array."""
    volume = scan("float32")
    volume[5, 7, 9] = bad
    messages = set()
    for layout in layouts(volume).values():
        with pytest.raises(ValueError) as error:
            isoscope.marching_cubes(layout, 0.0, backend="cpu")
        messages.add(str(error.value))
    assert len(messages) == 1
    message = messages.pop()
    assert "at index (5, 7, 9)" in message and "\n" not in message


def test_a_level_outside_the_range_is_refused_after_the_first_pass():
    volume = np.asfortranarray(scan("int16"))
    words = f"level 40000 is outside the data range [{volume.min()}, {volume.max()}]; pick a level inside it"
    with pytest.raises(ValueError) as error:
        isoscope.marching_cubes(volume, 40000, backend="cpu")
    assert str(error.value) == words
    with pytest.raises(ValueError, match="not finite"):
        isoscope.marching_cubes(volume, float("nan"), backend="cpu")


def test_no_copy_of_the_volume_is_made(tmp_path):
    """A 160^3 int16 scan in Fortran order (8 MB) as a memory map: the one-shot call allocates less than the
    volume itself (a C-ordered copy would be 8 MB, a float32 one 16 MB), for its words, counts and mesh."""
    x, y, z = np.meshgrid(*[np.linspace(-1, 1, 160)] * 3, indexing="ij")
    ball = ((0.5 - np.sqrt(x * x + y * y + z * z)) * 2000).astype(np.int16)
    path = tmp_path / "ball.npy"
    np.save(path, np.asfortranarray(ball))
    mapped = np.load(path, mmap_mode="r")
    assert mapped.flags.f_contiguous and not mapped.flags.c_contiguous
    isoscope.marching_cubes(mapped, 0, backend="cpu")   # compiled and warm
    tracemalloc.start()
    try:
        verts, faces, _, _ = isoscope.marching_cubes(mapped, 0, backend="cpu")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(faces) > 50_000
    assert peak < ball.nbytes * 0.8, f"{peak / 1e6:.1f} MB allocated for an {ball.nbytes / 1e6:.1f} MB volume"
    assert_identical(outward_marching_cubes(mapped, 0, backend="cpu"),
                     marching_cubes_reference(ball.astype(np.float32), 0, (1, 1, 1), True))


def test_auto_decides_the_backend_once(monkeypatch):
    """backend="auto" looks for a GL context once a process: later calls ask nothing of GL."""
    from isoscope.gpu import context
    volume = scan("float32")
    first = isoscope.marching_cubes(volume, 0.5)

    def no_more(*args, **kwargs):
        raise AssertionError("GL asked again")
    monkeypatch.setattr(context, "current_or_standalone", no_more)
    monkeypatch.setattr(context, "standalone", no_more)
    assert_identical(isoscope.marching_cubes(volume, 0.5), first)
    assert context.one_shot_backend() in ("cpu", "gpu")


def test_without_gl_the_search_runs_once_and_version_says_what_auto_gives():
    """Where there is no GL at all, the failed context search is remembered (it cost 10-15 ms a call), and
    `isoscope --version` names the one-shot backend."""
    script = ("import numpy as np, isoscope\n"
              "from isoscope.gpu import context\n"
              "tries = []\n"
              "real = context.standalone\n"
              "context.standalone = lambda *a, **k: (tries.append(1), real(*a, **k))[1]\n"
              "v = np.random.default_rng(0).normal(size=(20, 20, 20)).astype(np.float32)\n"
              "for _ in range(3):\n"
              "    isoscope.marching_cubes(v, 0.0)\n"
              "print(len(tries), context.one_shot_backend())\n")
    env = {**__import__("os").environ, **NO_GL}
    env.pop("DISPLAY", None)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["1", "cpu"]
    version = subprocess.run([sys.executable, "-m", "isoscope", "--version"], capture_output=True, text=True,
                             env=env, timeout=120)
    assert "one-shot calls" in version.stdout and "the compiled CPU extractor" in version.stdout


@pytest.mark.parametrize("backend", ["gpu"])
@pytest.mark.parametrize("dtype", ["uint8", ">i2", "float64"])
def test_the_gpu_takes_every_layout_as_it_is(dtype, backend):
    """The GPU's upload puts any layout in texel order a slab at a time (a Fortran array in slabs of axis 2, each
    a contiguous block of its memory; big-endian 16-bit samples stay 16-bit): the same faces as the CPU's."""
    volume = scan(dtype)
    level = level_of(volume)
    want = marching_cubes_reference(np.ascontiguousarray(volume, dtype=np.float32), level, (1, 1, 1), True)
    for name, layout in layouts(volume).items():
        verts, faces, _, _ = outward_marching_cubes(layout, level, backend=backend)
        assert np.array_equal(faces, want[1]) and np.array_equal(verts, want[0]), name
        with isoscope.Extractor(layout, backend=backend) as extractor:
            extractor.extract(level)
            assert np.array_equal(extractor.read_mesh()[1], want[1]), name


def test_label_maps_chunks_and_isosurface_take_nibabel_s_order(tmp_path):
    """label_surfaces, the chunked extraction and isosurface() on Fortran-ordered arrays (a NIfTI written and
    read back by nibabel, the independent reader) give what they give on the C-ordered array."""
    import nibabel
    volume = scan("int16", shape=(40, 36, 44))
    labels = np.digitize(volume, [-6000, 0, 6000]).astype(np.uint8)
    fortran_labels = np.asfortranarray(labels)
    for key, (verts, faces, normals) in isoscope.label_surfaces(labels, backend="cpu").items():
        other = isoscope.label_surfaces(fortran_labels, backend="cpu")[key]
        for a, b in zip((verts, faces, normals), other):
            np.testing.assert_array_equal(a, b)
    level = level_of(volume)
    whole = outward_marching_cubes(volume, level, backend="cpu")
    for chunks in (16, (40, 10, 44)):
        for a, b in zip(outward_marching_cubes(np.asfortranarray(volume), level, backend="cpu", chunks=chunks), whole):
            np.testing.assert_array_equal(a, b)
    path = tmp_path / "scan.nii"
    nibabel.save(nibabel.Nifti1Image(volume, np.eye(4)), path)
    given = np.asarray(nibabel.load(path).dataobj)
    assert given.flags.f_contiguous and not given.flags.c_contiguous
    mesh = isoscope.isosurface(given, level)
    want = isoscope.isosurface(volume, level)
    np.testing.assert_array_equal(mesh.faces, want.faces)
    np.testing.assert_array_equal(mesh.vertices, want.vertices)
