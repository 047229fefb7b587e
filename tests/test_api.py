"""isoscope.marching_cubes speaks scikit-image's conventions and rejects bad input clearly."""
import numpy as np
import pytest
from skimage import measure
from support.mesh_checks import sign_changing_edges

import isoscope
from isoscope.api import outward_marching_cubes
from isoscope.core.layout import EDGE_MARGIN


def sphere(n=32, r=0.55, centre=(0.02, -0.03, 0.01)):
    x, y, z = np.meshgrid(*[np.linspace(-1, 1, n)] * 3, indexing="ij")
    return (np.sqrt((x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2) - r).astype(np.float32)


def sorted_rows(a):
    return a[np.lexsort(a.T[::-1])]


@pytest.mark.parametrize("backend", ["cpu", "gpu"])
def test_vertices_match_scikit_image_on_a_generic_field(backend):
    """Same vertex per crossing edge (array-index order, scaled by spacing) as skimage's marching cubes."""
    volume = sphere()
    spacing = (1.0, 0.5, 2.0)
    verts, faces, normals, _ = isoscope.marching_cubes(volume, 0.0, spacing=spacing, backend=backend)
    sk_verts, sk_faces, _, _ = measure.marching_cubes(volume, 0.0, spacing=spacing)
    assert len(verts) == len(sk_verts) == sign_changing_edges(volume, 0.0)
    # Equal up to the 1/256-of-an-edge margin that keeps our vertices off grid points.
    np.testing.assert_allclose(sorted_rows(verts), sorted_rows(sk_verts), atol=max(spacing) / 256 + 1e-4)
    assert faces.dtype == np.int32 and faces.shape[1] == 3
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    # The outward mesh's values are the field at the vertex: the level, but for the edge margin's shift.
    values = outward_marching_cubes(volume, 0.0, spacing=spacing, backend=backend)[3]
    largest_step = max(np.abs(np.diff(volume, axis=a)).max() for a in range(3))
    assert np.abs(values).max() <= largest_step / 256 + 1e-6


def test_level_none_is_the_middle_of_the_range():
    volume = sphere()
    mid = (float(volume.min()) + float(volume.max())) / 2
    a = isoscope.marching_cubes(volume, backend="cpu")
    b = isoscope.marching_cubes(volume, mid, backend="cpu")
    np.testing.assert_array_equal(a[1], b[1])


@pytest.mark.gl
def test_ascent_on_a_field_equals_descent_on_its_negation():
    volume = sphere()
    a = isoscope.marching_cubes(volume, 0.0, gradient_direction="ascent", backend="gpu")
    b = isoscope.marching_cubes(-volume, 0.0, gradient_direction="descent", backend="gpu")
    np.testing.assert_array_equal(a[1], b[1])
    np.testing.assert_allclose(a[0], b[0], atol=1e-6)
    np.testing.assert_allclose(a[2], -b[2], atol=1e-6)  # scikit-image's normals point down the gradient
    np.testing.assert_array_equal(a[3], b[3])  # its values are spreads, the same either way


@pytest.mark.parametrize("backend", ["auto", "gpu", "cpu"])
@pytest.mark.gl
def test_auto_backend_is_the_gpu_on_hardware_and_the_cpu_on_a_software_renderer(gl_ctx, monkeypatch, backend):
    # GPU and CPU meshes are the same by design, so only the extractor's own record of an
    # extraction can tell which ran: a spy on Extractor.extract that still runs the real one.
    from isoscope.gpu.context import is_software_renderer
    from isoscope.gpu.cubes import Extractor
    levels = []
    real_extract = Extractor.extract
    monkeypatch.setattr(Extractor, "extract", lambda self, level: levels.append(level) or real_extract(self, level))
    verts, faces, _, _ = isoscope.marching_cubes(sphere(20), 0.0, backend=backend)
    # One-shot "auto": llvmpipe runs the compute passes on these same cores, slower than the compiled kernels.
    runs_on_gpu = backend == "gpu" or (backend == "auto" and not is_software_renderer(gl_ctx))
    assert levels == ([0.0] if runs_on_gpu else [])
    assert len(faces) > 0
    # Resident "auto" chooses as one-shot calls do (no window's context is current here); given a context, the GPU.
    from isoscope.cpu.extractor import CpuExtractor
    with isoscope.Extractor(sphere(20)) as resident:
        assert isinstance(resident, CpuExtractor if is_software_renderer(gl_ctx) else Extractor)
    with isoscope.Extractor(sphere(20), ctx=gl_ctx) as resident:
        assert isinstance(resident, Extractor)


@pytest.mark.gl
def test_integer_and_boolean_volumes_are_accepted():
    volume = (sphere(16) < 0).astype(np.uint8) * 200
    verts, faces, _, _ = isoscope.marching_cubes(volume, 100, backend="gpu")
    assert len(verts) == sign_changing_edges(volume.astype(np.float32), 100.0)


BAD = [
    (np.zeros((4, 4)), 0.0, {}, "3-D"),
    (np.zeros((4, 1, 4)), 0.0, {}, "shorter than 2"),
    (np.arange(27.0).reshape(3, 3, 3), 99.0, {}, "outside the data range"),
    (np.where(np.arange(27) == 4, np.nan, 1.0).reshape(3, 3, 3), 0.5, {}, "NaN/Inf"),
    (np.where(np.arange(27) == 4, np.inf, 1.0).reshape(3, 3, 3), 0.5, {}, "NaN/Inf"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"spacing": (1.0, -1.0, 1.0)}, "positive"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"spacing": (1.0, 1.0)}, "3 values"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"spacing": "abc"}, "spacing"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"gradient_direction": "up"}, "gradient_direction"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"backend": "cuda"}, "backend"),
    (np.array([["a"] * 2] * 2 * 2).reshape(2, 2, 2), 0.0, {}, "dtype"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"step_size": 0}, "step_size"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"step_size": 1.5}, "step_size"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"step_size": 3}, "shorter than 2"),
    (np.arange(27.0).reshape(3, 3, 3), 5.0, {"method": "dual"}, "method"),
]


@pytest.mark.parametrize("volume, level, kwargs, words", BAD)
def test_bad_input_raises_one_line_value_error(volume, level, kwargs, words):
    with pytest.raises(ValueError) as err:
        isoscope.marching_cubes(volume, level, **kwargs)
    message = str(err.value)
    assert words in message and "\n" not in message


@pytest.mark.parametrize("volume, level, kwargs, words", [bad for bad in BAD if "backend" not in bad[2]])
def test_bad_input_gets_the_same_error_on_the_cpu_backends(volume, level, kwargs, words):
    messages = []
    for backend in ("cpu", "numpy"):
        with pytest.raises(ValueError) as err:
            isoscope.marching_cubes(volume, level, backend=backend, **kwargs)
        messages.append(str(err.value))
    assert messages[0] == messages[1] and words in messages[0]


@pytest.mark.parametrize("options", [{}, {"gradient_direction": "ascent", "spacing": (0.5, 1.0, 2.0)},
                                     {"smooth": 2}, {"sharp_features": 30}, {"step_size": 2},
                                     {"mask": np.indices((32, 32, 32)).sum(axis=0) < 40}])
def test_cpu_backend_gives_the_numpy_backend_s_mesh(options):
    """backend="cpu" (compiled kernels) and "numpy" (the reference) make one mesh, whatever the options."""
    volume = sphere(32)
    compiled = isoscope.marching_cubes(volume, 0.0, backend="cpu", **options)
    reference = isoscope.marching_cubes(volume, 0.0, backend="numpy", **options)
    assert len(compiled[1]) > 0
    for a, b in zip(compiled, reference):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)


def test_cpu_backend_takes_integer_volumes():
    volume = (sphere(16) < 0).astype(np.uint8) * 200
    verts, faces, _, _ = isoscope.marching_cubes(volume, 100, backend="cpu")
    assert len(verts) == sign_changing_edges(volume.astype(np.float32), 100.0)
    np.testing.assert_array_equal(faces, isoscope.marching_cubes(volume, 100, backend="numpy")[1])


@pytest.mark.parametrize("step", [2, 3])
@pytest.mark.gl
def test_step_size_gives_scikit_image_s_coarse_mesh(step):
    from scipy.spatial import cKDTree
    from skimage import measure
    volume = sphere(64)
    spacing = (0.5, 1.0, 2.0)
    gpu = isoscope.marching_cubes(volume, 0.0, spacing=spacing, step_size=step, gradient_direction="ascent",
                                  backend="gpu")
    cpu = isoscope.marching_cubes(volume, 0.0, spacing=spacing, step_size=step, gradient_direction="ascent",
                                  backend="cpu")
    theirs = measure.marching_cubes(volume, 0.0, spacing=spacing, step_size=step, gradient_direction="ascent")
    np.testing.assert_array_equal(gpu[1], cpu[1])
    np.testing.assert_allclose(gpu[0], cpu[0], atol=1e-5)
    assert len(gpu[0]) == len(theirs[0]) and len(gpu[1]) == len(theirs[1])
    distance, _ = cKDTree(theirs[0]).query(gpu[0])
    # The same vertices, in the same (full-grid) units, but for ours kept EDGE_MARGIN of an edge
    # (step * spacing long) off grid points where scikit-image's come closer.
    assert np.mean(distance < 1e-4) > 0.98
    assert distance.max() <= float(EDGE_MARGIN) * step * max(spacing) + 1e-5
    full = isoscope.marching_cubes(volume, 0.0, spacing=spacing, gradient_direction="ascent", backend="cpu")
    assert len(gpu[1]) < len(full[1]) / (step * step) * 1.2


def test_allow_degenerate_and_method_are_accepted_and_change_nothing():
    volume = sphere(20)
    base = isoscope.marching_cubes(volume, 0.0, backend="cpu")
    for kwargs in ({"allow_degenerate": False}, {"method": "lorensen"}, {"method": "lewiner"}):
        other = isoscope.marching_cubes(volume, 0.0, backend="cpu", **kwargs)
        for a, b in zip(base, other):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("backend", ["cpu", "numpy", "gpu"])
def test_extractor_of_every_backend_gives_one_mesh(backend):
    from isoscope.cpu.cubes import marching_cubes_reference
    volume = sphere(24)
    with isoscope.Extractor(volume, (0.5, 1.0, 2.0), "ascent", backend=backend) as ex:
        assert isinstance(ex, isoscope.Extractor)
        assert ex.value_range == (float(volume.min()), float(volume.max()))
        for level in (0.0, 0.2):
            counts = ex.extract(level)
            mesh = ex.read_mesh()
            assert counts == (len(mesh[0]), len(mesh[1]))
            want = marching_cubes_reference(volume, level, (0.5, 1.0, 2.0), descent=False)
            np.testing.assert_array_equal(mesh[1], want[1])
            np.testing.assert_allclose(mesh[0], want[0], atol=1e-5)


def test_extractor_backend_choice_and_errors(monkeypatch):
    from isoscope.cpu.extractor import CpuExtractor
    from isoscope.gpu import context
    # What a machine with no GL answers: no window's context, no standalone one, and so the CPU one-shot.
    monkeypatch.setattr(context, "_window_context_current", lambda: False)
    monkeypatch.setattr(context, "_one_shot", None)
    monkeypatch.setattr(context, "_standalone", None)
    monkeypatch.setattr(context, "_no_standalone", context.GLUnavailable("no OpenGL 4.3 context here"))
    with isoscope.Extractor(sphere(12)) as ex:
        assert type(ex) is CpuExtractor and ex.backend == "cpu"
    assert not isinstance(np.zeros(3), isoscope.Extractor)
    with pytest.raises(ValueError, match="backend"):
        isoscope.Extractor(sphere(12), backend="cuda")
    with pytest.raises(ValueError, match="GPU extractor"):
        isoscope.Extractor(sphere(12), backend="cpu", limits=object())
    for backend in ("cpu", "numpy"):
        with pytest.raises(ValueError, match="outside the data range"):
            isoscope.Extractor(sphere(12), backend=backend).extract(9.0)


@pytest.mark.parametrize("direction", ["descent", "ascent"])
@pytest.mark.parametrize("backend", ["cpu", "numpy"])
def test_chunked_extraction_on_the_cpu_equals_the_whole_volume_mesh(backend, direction):
    rng = np.random.default_rng(5)
    volume = rng.integers(-2, 3, size=(21, 18, 40)).astype(np.float32)  # ties on the seams too
    whole = isoscope.marching_cubes(volume, 0.0, gradient_direction=direction, backend="numpy")
    chunked = isoscope.marching_cubes(volume, 0.0, gradient_direction=direction, backend=backend, chunks=(8, 7, 16))
    for a, b in zip(chunked, whole):
        np.testing.assert_array_equal(a, b)


def test_a_cluster_worker_with_no_gl_extracts_on_the_cpu(monkeypatch):
    """`--workers N` where no OpenGL 4.3 context can be had: each worker's boxes go to the CPU extractor."""
    from isoscope.big import cluster
    from isoscope.big.chunked import chunk_boxes, merge
    from isoscope.gpu import context

    def no_gl(*args, **kwargs):
        raise context.GLUnavailable("no OpenGL 4.3 context: none here")
    monkeypatch.setattr(context, "standalone", no_gl)
    monkeypatch.setattr(cluster, "_local", type(cluster._local)())
    volume = sphere(30)
    parts = [cluster._extract_task(volume, box, 0.0, (1.0, 1.0, 1.0), False) for box in chunk_boxes(volume.shape, 12)]
    assert cluster._local.backend == "cpu"
    want = outward_marching_cubes(volume, 0.0, gradient_direction="ascent", backend="numpy")
    for a, b in zip(merge(parts, volume.shape), want):
        np.testing.assert_array_equal(a, b)


def test_label_surfaces_on_the_cpu_backends_agree():
    rng = np.random.default_rng(11)
    labels = rng.integers(0, 4, size=(16, 20, 24)).astype(np.uint8)
    compiled = isoscope.label_surfaces(labels, spacing=(0.5, 1.0, 2.0), backend="cpu")
    reference = isoscope.label_surfaces(labels, spacing=(0.5, 1.0, 2.0), backend="numpy")
    assert sorted(compiled) == sorted(reference) == [1, 2, 3]
    for label in compiled:
        for a, b in zip(compiled[label], reference[label]):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("options", [{}, {"gradient_direction": "ascent", "spacing": (0.5, 1.0, 2.0)}, {"smooth": 2},
                                     {"mask": np.indices((24, 24, 24)).sum(axis=0) < 30}])
def test_tetrahedra_cpu_backend_gives_the_numpy_backend_s_mesh(options):
    volume = sphere(24)
    compiled = isoscope.marching_tetrahedra(volume, 0.0, backend="cpu", **options)
    reference = isoscope.marching_tetrahedra(volume, 0.0, backend="numpy", **options)
    assert len(compiled[1]) > 0
    for a, b in zip(compiled, reference):
        np.testing.assert_array_equal(a, b)
