"""isoscope export on a dask.distributed cluster: 2 worker processes, the same file as one process."""
from __future__ import annotations

import os

import numpy as np
import pytest
import trimesh
import zarr
from support.command import NO_GL, isoscope, isoscope_here

from isoscope.big import cluster
from isoscope.big.cluster import ClusterError, marching_cubes_on_cluster
from isoscope.cli import main as cli

distributed = pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def noise_zarr(tmp_path_factory):
    from scipy.ndimage import gaussian_filter
    folder = tmp_path_factory.mktemp("cluster")
    field = gaussian_filter(np.random.default_rng(3).normal(size=(40, 34, 50)), 2).astype(np.float32)
    np.save(folder / "v.npy", field)
    zarr.create_array(str(folder / "v.zarr"), shape=field.shape, chunks=(16, 16, 16), dtype="f4")[:] = field
    return folder, field


@pytest.mark.gl
def test_two_worker_local_cluster_writes_the_single_process_file(noise_zarr):
    folder, _ = noise_zarr
    single = isoscope_here("export", folder / "v.npy", "--iso", "0", "--out", folder / "single.ply")
    # The cluster runs in a command of its own: its worker processes and dask's warning filters stay there.
    spread = isoscope("export", folder / "v.zarr", "--iso", "0", "--out", folder / "spread.ply",
                      "--workers", "2", "--chunk", "12")
    chunked = isoscope_here("export", folder / "v.zarr", "--iso", "0", "--out", folder / "chunked.ply")  # Zarr: chunked
    assert single.returncode == 0 and spread.returncode == 0 and chunked.returncode == 0, spread.stderr
    assert (folder / "spread.ply").read_bytes() == (folder / "single.ply").read_bytes()
    assert (folder / "chunked.ply").read_bytes() == (folder / "single.ply").read_bytes()


@pytest.mark.gl
def test_two_workers_on_a_machine_with_no_gl_export_the_gpu_mesh(noise_zarr):
    """Workers without GL extract with the compiled CPU extractor: the same faces as the GPU's single-process
    file, positions and normals within float32 rounding (the two backends round the normal's last bit apart)."""
    folder, _ = noise_zarr
    gpu = isoscope_here("export", folder / "v.npy", "--iso", "0", "--out", folder / "gpu.ply")
    no_gl = isoscope("export", folder / "v.zarr", "--iso", "0", "--out", folder / "no-gl.ply", "--workers", "2",
                     "--chunk", "12", env_add=NO_GL, env_drop=("DISPLAY",))
    assert gpu.returncode == 0 and no_gl.returncode == 0, no_gl.stderr
    probe = isoscope("--version", env_add=NO_GL, env_drop=("DISPLAY",))
    assert "no OpenGL here" in probe.stdout and "CPU extractor" in probe.stdout, probe.stdout   # really no GL
    a, b = (trimesh.load(folder / name, process=False) for name in ("gpu.ply", "no-gl.ply"))
    assert len(a.faces) > 1000
    assert np.array_equal(a.faces, b.faces)
    assert np.allclose(a.vertices, b.vertices, rtol=0, atol=1e-5)
    assert np.allclose(a.vertex_normals, b.vertex_normals, rtol=0, atol=1e-5)


class DiesOnRead:
    """A volume whose every read kills the worker process reading it."""
    shape, dtype = (20, 20, 20), np.dtype(np.float32)

    def __getitem__(self, index):
        os._exit(3)


@pytest.fixture(scope="module")
def scheduler():
    import dask
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):  # a dead worker fails the task at once
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as local:
            yield local.scheduler_address


def test_scheduler_address_progress_and_a_dying_worker(noise_zarr, scheduler, gl_ctx):
    from isoscope.api import outward_marching_cubes
    _, field = noise_zarr
    source = zarr.open(str(noise_zarr[0] / "v.zarr"), mode="r")
    seen = []
    mesh = marching_cubes_on_cluster(source, 0.0, (1.0, 1.0, 1.0), True, (15, 15, 15), scheduler=scheduler,
                                     progress=lambda fraction, message: seen.append(fraction))
    for got, expected in zip(mesh, outward_marching_cubes(field, 0.0)):   # "auto" here as on the workers
        np.testing.assert_array_equal(got, expected)
    assert seen == sorted(seen) and seen[-1] == 1.0 and len(seen) == 3 * 3 * 4
    with pytest.raises(ClusterError, match="a dask worker failed on a chunk.*KilledWorker"):
        marching_cubes_on_cluster(DiesOnRead(), 0.0, (1.0, 1.0, 1.0), True, 10, scheduler=scheduler)


def test_unreachable_scheduler_is_one_line_exit_1_and_no_file(noise_zarr, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1)
    status = cli.main(["export", str(noise_zarr[0] / "v.zarr"), "--iso", "0", "--out", str(tmp_path / "m.ply"),
                       "--scheduler", "tcp://127.0.0.1:9"])
    error = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and len(error) == 1 and "cannot reach the dask scheduler at tcp://127.0.0.1:9" in error[0]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.gl
def test_a_full_disk_is_one_line_exit_1_and_no_partial_file(noise_zarr, tmp_path):
    """The file size limit (RLIMIT_FSIZE) stands in for a full disk: writes past it fail as ENOSPC would."""
    import resource
    import signal
    import subprocess
    import sys

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # fail the write (EFBIG) instead of killing the process
        resource.setrlimit(resource.RLIMIT_FSIZE, (64 << 10, 64 << 10))

    result = subprocess.run([sys.executable, "-m", "isoscope", "export", str(noise_zarr[0] / "v.zarr"), "--iso", "0",
                             "--chunk", "20", "--out", str(tmp_path / "m.ply")], capture_output=True, text=True,
                            preexec_fn=limit, timeout=120)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 1 and len(lines) == 1 and "no partial file" in lines[0], result.stderr
    assert list(tmp_path.iterdir()) == []
