"""Hostile input from users' reports (issue 22), each run as a user would: a real `python -m isoscope`
subprocess on real files, held to the promise (exit 2, one `isoscope: error:` line, seconds, little
memory; tests/support/command.py), plus the pure rules behind the refusals."""
from __future__ import annotations

import json

import numpy as np
import pytest
from support.command import isoscope_here, refused, succeeded_here
from support.forked import STRESS


@pytest.fixture
def raw8(tmp_path):
    path = tmp_path / "tiny.raw"
    np.arange(8, dtype=np.uint8).tofile(path)
    return path


# --- 3. dims whose product wraps, or that are not integers at all --------------------------------------

@pytest.mark.parametrize("dims, words", [(("4294967296", "4294967296", "8"), ("--dims", "2147483647")),
                                         (("2147483647", "2147483647", "8"), ("voxels", "more than"))])
def test_dims_whose_int64_product_wraps_are_refused(raw8, tmp_path, dims, words):
    refused("export", raw8, "--dims", *dims, "--out", tmp_path / "o.stl", words=words)


def test_sidecar_dims_of_1e308_are_one_line(raw8, tmp_path):
    (tmp_path / "tiny.raw.json").write_text(json.dumps({"dims": [1e308, 1, 1]}))
    refused("export", raw8, "--out", tmp_path / "o.stl", words=("dims", "positive whole numbers"))


def test_three_positive_takes_python_ints_and_refuses_overflow():
    from isoscope.volumes.errors import VolumeError
    from isoscope.volumes.raw_format import MAX_DIM, three_positive
    assert three_positive([4, 5, 6], "--dims", int, "x") == (4, 5, 6)
    for bad in ([1e308, 1, 1], [float("inf"), 1, 1], [MAX_DIM + 1, 1, 1], [2.5, 1, 1], [True, 1, 1], 5, "123"):
        with pytest.raises(VolumeError):
            three_positive(bad, "--dims", int, "x")
    with pytest.raises(VolumeError):
        three_positive([float("inf"), 1, 1], "--spacing", float, "x")


# --- 7. a path that starts with a dash ----------------------------------------------------------------

@pytest.fixture
def dash_npy(tmp_path):
    np.save(tmp_path / "-lead.npy", np.random.default_rng(0).random((12, 12, 12)).astype(np.float32))
    return tmp_path


def test_a_dash_path_without_dashes_says_to_put_it_after_double_dash(dash_npy):
    line = refused("export", "-lead.npy", "--out", "o.stl", cwd=dash_npy, words=("VOLUME", "'--'", "-lead.npy"))
    assert line.startswith("isoscope: error:") and line.endswith("(see isoscope export --help)")


@pytest.mark.parametrize("order", ["before", "after"])
def test_a_dash_path_after_double_dash_exports(dash_npy, order):
    from support.command import succeeded
    args = ["--", "-lead.npy", "--out", "o.stl", "--iso", "0.5"] if order == "before" else \
        ["--out", "o.stl", "--iso", "0.5", "--", "-lead.npy"]
    succeeded("export", *args, cwd=dash_npy)
    assert (dash_npy / "o.stl").stat().st_size > 84


def test_volume_after_dashes_moves_only_options():
    from isoscope.cli.arguments import volume_after_dashes
    assert volume_after_dashes(["--", "-v.npy", "--out", "o"]) == ["--out", "o", "--", "-v.npy"]
    assert volume_after_dashes(["--out", "o", "--", "-v.npy"]) == ["--out", "o", "--", "-v.npy"]
    assert volume_after_dashes(["--", "-v.npy", "extra"]) == ["--", "-v.npy", "extra"]


# --- 8. colour-bar labels without float noise ---------------------------------------------------------

@pytest.mark.parametrize("value, low, high, text", [
    (1.251e-17, 1.251e-17, 1.0, "0"), (-3e-12, -3e-12, 255.0, "0"), (1.0, 1.251e-17, 1.0, "1"),
    (1000.0, 1000.0, 1001.0, "1000"), (1001.0, 1000.0, 1001.0, "1001"), (0.1 + 0.2, 0.0, 0.1 + 0.2, "0.3"),
    (-10 / 3, -10 / 3, 7.0, "-3.33"), (1e-20, 1e-20, 3e-20, "1e-20"), (123456.789, 0.0, 123456.789, "123457"),
    (5.0, 5.0, 5.0, "5"), (1000.25, 1000.0, 1000.5, "1000.25")])
def test_colorbar_tick_labels(value, low, high, text):
    from isoscope.viewer.gfx.colorbar import tick_label
    assert tick_label(value, low, high) == text


def test_colorbar_draws_zero_for_a_noise_low_end():
    from types import SimpleNamespace

    from isoscope.viewer.gfx.colorbar import draw_colorbar
    pixels = np.zeros((300, 300, 3), np.uint8)
    lut = np.linspace(0, 1, 256)[:, None].repeat(3, 1)
    noisy = draw_colorbar(pixels, SimpleNamespace(value_range=(1.251e-17, 1.0), source="dose", lut=lut))
    clean = draw_colorbar(pixels, SimpleNamespace(value_range=(0.0, 1.0), source="dose", lut=lut))
    assert np.array_equal(noisy, clean)


# --- 4. spacing whose mesh overflows float32 or collapses to a point ----------------------------------

@pytest.fixture(scope="module")
def sphere_npy(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sphere")
    axis = np.linspace(-1, 1, 24)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    np.save(folder / "sphere.npy", np.sqrt(x * x + y * y + z * z).astype(np.float32))
    return folder / "sphere.npy"


@pytest.mark.parametrize("spacing", [("1e300", "1", "1"), ("1e-300", "1e-300", "1e-300"), ("1", "1", "inf")])
def test_spacing_that_breaks_float32_is_refused_on_the_command_line(sphere_npy, tmp_path, spacing):
    refused("export", sphere_npy, "--iso", "0.5", "--spacing", *spacing, "--out", tmp_path / "o.stl",
            words=("spacing",))
    assert not (tmp_path / "o.stl").exists()


def test_a_sidecar_spacing_of_1e_minus_300_is_refused(tmp_path):
    np.linspace(0, 1, 64, dtype=np.float32).tofile(tmp_path / "v.raw")
    (tmp_path / "v.raw.json").write_text(json.dumps({"dims": [4, 4, 4], "dtype": "float32",
                                                     "spacing": [1e-300, 1, 1]}))
    refused("export", tmp_path / "v.raw", "--out", tmp_path / "o.stl", words=("spacing", "out of range"))


def test_as_spacing_is_the_one_rule():
    from isoscope.validation import MAX_SPACING, MIN_SPACING, as_spacing
    assert as_spacing((MIN_SPACING, 1, MAX_SPACING)) == (MIN_SPACING, 1.0, MAX_SPACING)
    assert as_spacing([0.5, 0.5, 2], shape=(10, 10, 10)) == (0.5, 0.5, 2.0)
    for bad in ((1e300, 1, 1), (1e-300, 1, 1), (MIN_SPACING / 2, 1, 1), (MAX_SPACING * 2, 1, 1), (0, 1, 1),
                (np.inf, 1, 1), (np.nan, 1, 1), (1, 1), "abc"):
        with pytest.raises(ValueError):
            as_spacing(bad)


def test_the_python_api_refuses_the_same_spacing():
    import isoscope
    volume = np.random.default_rng(1).random((8, 8, 8)).astype(np.float32)
    for spacing in ((1e300, 1, 1), (1e-300, 1e-300, 1e-300)):
        with pytest.raises(ValueError, match="out of range"):
            isoscope.marching_cubes(volume, 0.5, spacing=spacing, backend="cpu")


def test_spacing_at_the_bounds_keeps_the_mesh_finite_and_distinct():
    import isoscope
    from isoscope.validation import MAX_SPACING, MIN_SPACING
    axis = np.linspace(-1, 1, 16)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    field = np.sqrt(x * x + y * y + z * z).astype(np.float32)
    unit = isoscope.marching_cubes(field, 0.6, backend="cpu")[0]
    for s in (MIN_SPACING, MAX_SPACING):
        verts, _, normals, _ = isoscope.marching_cubes(field, 0.6, spacing=(s, s, s), backend="cpu")
        assert np.isfinite(verts).all() and len(np.unique(verts, axis=0)) == len(unit)
        np.testing.assert_allclose(verts / np.float32(s), unit, rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-5)


# --- 5. --labels on a scan: one file per grey value ---------------------------------------------------

@pytest.fixture(scope="module")
def label_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("labels")
    rng = np.random.default_rng(5)
    np.save(folder / "mri_whole.npy", np.round(rng.random((32, 32, 32)) * 300).astype(np.float32))
    np.save(folder / "mri.npy", rng.random((32, 32, 32)).astype(np.float32))
    blocks = np.arange(8 ** 3).reshape(8, 8, 8) % 300 + 1   # 300 labels, each in flat 4^3 blocks
    np.save(folder / "many_labels.npy", np.kron(blocks, np.ones((4, 4, 4), np.int32)).astype(np.int32))
    seg = np.zeros((24, 24, 24), np.uint8)
    seg[4:10, 4:10, 4:10], seg[12:20, 12:20, 12:20] = 1, 2
    np.save(folder / "seg.npy", seg)
    return folder


def test_a_float_scan_with_fractions_is_not_a_label_map(label_files, tmp_path):
    refused("export", label_files / "mri.npy", "--labels", "--out", tmp_path / "m.stl",
            words=("not a label map", "leave out --labels"))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("one_file", [False, True])
def test_more_labels_than_the_limit_writes_nothing_and_says_how_many(label_files, tmp_path, one_file):
    out = tmp_path / ("m.ply" if one_file else "m.stl")
    line = refused("export", label_files / "many_labels.npy", "--labels", "--out", out,
                   *(["--one-file"] if one_file else []),
                   words=("300", "--max-labels 255", "--max-labels 300", "leave out --labels"))
    assert ("one file holding 300 meshes" if one_file else "300 files") in line
    assert list(tmp_path.iterdir()) == []


def test_max_labels_raises_and_lowers_the_limit(label_files, tmp_path):
    from support.command import succeeded
    refused("export", label_files / "seg.npy", "--labels", "--max-labels", "1", "--out", tmp_path / "s.stl",
            words=("2 distinct", "--max-labels 2"))
    refused("export", label_files / "seg.npy", "--labels", "--max-labels", "0", "--out", tmp_path / "s.stl",
            words=("--max-labels",))
    refused("export", label_files / "seg.npy", "--max-labels", "5", "--out", tmp_path / "s.stl",
            words=("--max-labels needs --labels",))
    assert list(tmp_path.iterdir()) == []
    succeeded("export", label_files / "seg.npy", "--labels", "--max-labels", "2", "--out", tmp_path / "s.stl")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s_label1.stl", "s_label2.stl"]


def test_label_surfaces_max_labels_refuses_before_extracting():
    from isoscope.labels import TooManyLabels, label_surfaces, labels_of
    labels = np.arange(27, dtype=np.int32).reshape(3, 3, 3)
    with pytest.raises(TooManyLabels) as caught:
        label_surfaces(labels, max_labels=25, backend="cpu")
    assert (caught.value.count, caught.value.limit) == (26, 25)
    assert len(label_surfaces(labels[:2, :2, :2], max_labels=25, backend="cpu")) == 7
    from types import SimpleNamespace
    whole = SimpleNamespace(data=np.array([[[0.0, 2.0], [300.0, 1.0]]] * 2, np.float32), value_range=(0.0, 300.0),
                            name="v")
    assert labels_of(whole).dtype == np.uint16


def test_labels_into_a_missing_folder_is_refused_before_the_work(label_files, tmp_path):
    refused("export", label_files / "seg.npy", "--labels", "--out", tmp_path / "nowhere" / "s.stl",
            words=("does not exist",))


# --- 2. --scheduler at something that is no dask scheduler; Ctrl-C on a local cluster -----------------

pytest.importorskip("dask.distributed")


@pytest.fixture
def serving():
    """serve(handler class) -> the port of a TCP server on 127.0.0.1 running in a thread until the test ends."""
    import socketserver
    import threading
    servers = []

    def serve(handler, server_class=socketserver.ThreadingTCPServer):
        server = server_class(("127.0.0.1", 0), handler)
        server.daemon_threads = True
        threading.Thread(target=server.serve_forever, daemon=True).start()
        servers.append(server)
        return server.server_address[1]
    yield serve
    for server in servers:
        server.shutdown()
        server.server_close()


def test_an_http_server_as_scheduler_is_refused_in_seconds(serving, sphere_npy, tmp_path):
    import http.server

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass
    port = serving(Quiet, http.server.ThreadingHTTPServer)
    refused("export", sphere_npy, "--iso", "0.5", "--out", tmp_path / "o.stl", "--scheduler",
            f"tcp://127.0.0.1:{port}", words=("not greet as a dask scheduler", "8786"), seconds=8)
    assert not (tmp_path / "o.stl").exists()


@pytest.mark.parametrize("reply", ["random", "huge length"])
def test_a_server_replying_garbage_is_refused_without_allocating_it(serving, sphere_npy, tmp_path, reply):
    import os
    import socketserver
    import struct
    import time
    greeting = os.urandom(4096) if reply == "random" else struct.pack("<Q", 3_540_000_000_000_000_000) + bytes(64)

    class Garbage(socketserver.BaseRequestHandler):
        def handle(self):
            self.request.sendall(greeting)
            time.sleep(2)
    port = serving(Garbage)
    refused("export", sphere_npy, "--iso", "0.5", "--out", tmp_path / "o.stl", "--scheduler",
            f"tcp://127.0.0.1:{port}", words=("did not answer as a dask scheduler",), seconds=8)


def test_probe_scheduler_tells_silence_garbage_and_nothing_apart(serving):
    import socket
    import socketserver
    import time

    from isoscope.big.cluster import ClusterError, NotAScheduler, probe_scheduler

    class Silent(socketserver.BaseRequestHandler):
        def handle(self):
            time.sleep(2)

    class Hangs_up(socketserver.BaseRequestHandler):
        def handle(self):
            self.request.sendall(b"\x10\x00\x00\x00\x00\x00\x00\x00abc")
    start = time.monotonic()
    with pytest.raises(NotAScheduler, match="within 0.5 s"):
        probe_scheduler(f"tcp://127.0.0.1:{serving(Silent)}", timeout=0.5)
    assert time.monotonic() - start < 2
    with pytest.raises(NotAScheduler, match="closed the connection after 3 of 16 bytes"):
        probe_scheduler(f"127.0.0.1:{serving(Hangs_up)}")
    with socket.socket() as unused:
        unused.bind(("127.0.0.1", 0))
        port = unused.getsockname()[1]
    with pytest.raises(ClusterError, match="cannot reach") as caught:
        probe_scheduler(f"tcp://127.0.0.1:{port}")
    assert caught.value.exit_status == 1
    with pytest.raises(NotAScheduler, match="no port"):
        probe_scheduler("tcp://127.0.0.1")
    probe_scheduler("tls://127.0.0.1:1")  # other schemes are left to dask


@pytest.fixture(scope="module")
def big_npy(tmp_path_factory):
    """A smooth 205^3 float64 field as np.save writes it: 65.7 MiB, over the old 64 MiB limit for dask.

    Written a plane at a time, so the test process stays small."""
    folder = tmp_path_factory.mktemp("big")
    n = 205
    axis = np.linspace(-1, 1, n)
    y, z = np.meshgrid(axis, axis, indexing="ij")
    with open(folder / "big.npy", "wb") as out:
        np.lib.format.write_array_header_1_0(out, {"descr": "<f8", "fortran_order": False, "shape": (n, n, n)})
        for x in axis:
            out.write(np.sqrt(x * x + y * y + z * z).tobytes())
    assert (folder / "big.npy").stat().st_size > 64 << 20
    return folder / "big.npy"


@pytest.mark.gl
def test_a_big_npy_opened_by_path_goes_to_dask_workers_by_path(big_npy, tmp_path):
    from support.command import succeeded
    succeeded("export", big_npy, "--iso", "0.5", "--out", tmp_path / "spread.stl", "--workers", "1")
    succeeded_here("export", big_npy, "--iso", "0.5", "--out", tmp_path / "single.stl")
    assert (tmp_path / "spread.stl").read_bytes() == (tmp_path / "single.stl").read_bytes()


@pytest.mark.gl
def test_a_big_raw_file_goes_to_dask_workers_by_path(big_npy, tmp_path):
    """A raw file of 64-256 MiB (read whole otherwise) is mapped for a cluster export, so its workers read it
    by name: the same file as the single-process export."""
    from support.command import succeeded
    field = np.load(big_npy, mmap_mode="r")
    raw = tmp_path / "big.raw"
    with open(raw, "wb") as out:
        for k in range(field.shape[2]):  # x fastest on disk: z planes of (y, x)
            out.write(np.ascontiguousarray(field[:, :, k].T).tobytes())
    flags = ("--dims", *map(str, field.shape), "--dtype", "float64", "--iso", "0.5")
    succeeded("export", raw, *flags, "--out", tmp_path / "spread.stl", "--workers", "1")
    succeeded_here("export", raw, *flags, "--out", tmp_path / "single.stl")
    assert (tmp_path / "spread.stl").read_bytes() == (tmp_path / "single.stl").read_bytes()


def test_shippable_maps_an_npy_read_whole_and_sends_its_name(sphere_npy, tmp_path):
    import pickle

    from isoscope.big.cluster import ClusterError, mapped_npy, shippable
    whole = np.load(sphere_npy)
    shipped = shippable(whole, str(sphere_npy))
    assert len(pickle.dumps(shipped)) < 1024 and np.array_equal(np.asarray(pickle.loads(pickle.dumps(shipped))), whole)
    other = tmp_path / "other.npy"
    np.save(other, whole[:, :, :10])
    assert mapped_npy(whole, str(other)) is whole  # a file holding something else is not taken for it
    assert mapped_npy(whole.astype(np.float64), str(sphere_npy)).dtype == np.float64
    big = np.broadcast_to(np.float64(0), (205, 205, 205))  # 65.7 MiB by its nbytes, none of it in memory
    with pytest.raises(ClusterError, match="open it by path"):
        shippable(big)  # an array of no file


def _workers(pid: int) -> set[str]:
    """The children of `pid` that multiprocessing spawned as processes (dask's workers), not its resource
    tracker."""
    found = set()
    for child in _children(pid):
        try:
            with open(f"/proc/{child}/cmdline", "rb") as cmdline:
                if b"spawn_main" in cmdline.read():
                    found.add(child)
        except OSError:
            pass
    return found


def _children(pid: int) -> set[str]:
    import glob
    found = set()
    for path in glob.glob(f"/proc/{pid}/task/*/children"):
        try:
            with open(path) as listing:
                found |= set(listing.read().split())
        except OSError:
            pass
    return found


@pytest.mark.parametrize("delay", [0.3, 1.0])
@pytest.mark.gl
def test_ctrl_c_during_a_local_cluster_export_is_exit_130_without_tracebacks(big_npy, tmp_path, delay):
    """Ctrl-C as a terminal sends it: SIGINT to the whole process group, workers included, once the workers
    are spawned (while they are, some 20 ms, this process ignores SIGINT: see cluster.py)."""
    import os
    import signal
    import subprocess
    import sys
    import time
    process = subprocess.Popen([sys.executable, "-m", "isoscope", "export", str(big_npy), "--iso", "0.5",
                                "--chunk", "16", "--workers", "2", "--out", str(tmp_path / "o.stl")],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        # both workers (the resource tracker, also a child, can come first: a Ctrl-C while the second worker is
        # being spawned is lost, as cluster.py says)
        while len(_workers(process.pid)) < 2 and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.05)
        time.sleep(delay)
        os.killpg(process.pid, signal.SIGINT)
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    assert process.returncode == 130, f"exit {process.returncode}: {err}"
    assert len(err.splitlines()) <= 1 and "Traceback" not in err, err
    assert not (tmp_path / "o.stl").exists()


@pytest.mark.gl
def test_no_dask_chatter_when_the_dashboard_port_is_taken(sphere_npy, tmp_path):
    import socket

    from support.command import succeeded
    with socket.socket() as taken:
        try:
            taken.bind(("127.0.0.1", 8787))
            taken.listen()
        except OSError:
            pass  # already in use: the case itself
        succeeded("export", sphere_npy, "--iso", "0.5", "--out", tmp_path / "o.stl", "--workers", "1")


# --- 1. render sizes the driver cannot make, or that take gigabytes -----------------------------------

@pytest.mark.parametrize("size", ["16384x16384", "11585x11585", "16384x8193", "5000x4000"])
def test_a_render_size_of_gigabytes_is_refused_before_allocating(sphere_npy, tmp_path, size):
    refused("render", sphere_npy, "--iso", "0.5", "--size", size, "--out", tmp_path / "r.png",
            words=("--size", "million pixels", "smaller --size"))
    assert not (tmp_path / "r.png").exists()


class FakeContext:
    def __init__(self, **info):
        self.info = {"GL_RENDERER": "FakeGL", **info}


def test_the_drivers_size_limits_are_the_least_of_them():
    from isoscope.viewer.ui.headless import check_render_size, max_render_size
    ctx = FakeContext(GL_MAX_RENDERBUFFER_SIZE=8192, GL_MAX_TEXTURE_SIZE=16384, GL_MAX_VIEWPORT_DIMS=(4096, 16384),
                      GL_MAX_FRAMEBUFFER_HEIGHT=2048)
    assert max_render_size(ctx) == (4096, 2048)
    assert max_render_size(FakeContext()) == (1 << 30, 1 << 30)
    check_render_size((4096, 2048), ctx)
    for size in ((4097, 100), (100, 2049)):
        with pytest.raises(ValueError, match="FakeGL can render, 4096x2048"):
            check_render_size(size, ctx)
    with pytest.raises(ValueError, match="million pixels"):
        check_render_size((4097, 4096))


def test_big_renders_get_fewer_samples():
    from isoscope.viewer.ui.headless import MULTISAMPLE_BYTES, render_samples
    assert render_samples((800, 600)) == render_samples((3840, 2160)) == 4
    assert render_samples((4096, 4096)) == 2
    for size in ((800, 600), (3840, 2160), (4096, 4096)):
        samples = render_samples(size)
        assert samples == 1 or 8 * size[0] * size[1] * samples <= MULTISAMPLE_BYTES


@pytest.mark.parametrize("options, words", [
    (("--workers", "100000"), ("--workers 100000", "at most")),
    (("--workers", "2", "--scheduler", "tcp://127.0.0.1:9"), ("give one of them",)),
    (("--scheduler", "http://127.0.0.1:80"), ("tcp://HOST:PORT", "not http://")),
    (("--scheduler", "tcp://127.0.0.1:99999"), ("no port",)),
    (("--labels", "--workers", "2"), ("leave out --workers",))])
def test_cluster_options_that_cannot_work_are_refused_before_any_cluster(sphere_npy, tmp_path, options, words):
    refused("export", sphere_npy, "--out", tmp_path / "o.stl", *options, words=words, seconds=5)


# --- Ctrl-C while the command starts ------------------------------------------------------------------------

@pytest.mark.gl
def _wait_for_numpy(process, seconds: float = 60.0) -> None:
    """Until the process has numpy's extension loaded: isoscope's own imports are under way."""
    import time
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and process.poll() is None:
        try:
            if "_multiarray_umath" in open(f"/proc/{process.pid}/maps").read():
                return
        except OSError:
            return
        time.sleep(0.002)


@pytest.mark.gl   # it interrupts renders, which need a GL context
def test_ctrl_c_at_any_moment_of_start_up_prints_nothing(tmp_path):
    """SIGINT at 8 (times ISOSCOPE_STRESS) seeded moments of a render's first half second once its imports
    begin (imports, argument parsing, imgui's native start, the GL context): never a traceback, nor nanobind's
    abort (one render in ten printed one or the other: a KeyboardInterrupt inside imgui's module start aborted
    the process); no half file, and a PNG that is there is whole (an interrupt after its rename still ends the
    command 130)."""
    import random
    import signal
    import subprocess
    import sys
    import time

    from PIL import Image

    rng = random.Random(22)
    out = tmp_path / "r.png"
    for _ in range(8 * STRESS):
        out.unlink(missing_ok=True)
        process = subprocess.Popen([sys.executable, "-m", "isoscope", "render", "torus", "--size", "160x120",
                                    "--out", out], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        _wait_for_numpy(process)  # past Python's own start (a Ctrl-C in its site import is Python's fatal error)
        time.sleep(rng.uniform(0.0, 0.5))
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=60)
        assert stderr == "", stderr[-2000:]
        assert not list(tmp_path.glob("*.partial"))
        if process.returncode == 0 or out.exists():  # an interrupt after the rename still ends the command 130
            assert Image.open(out).size == (160, 120)


@pytest.mark.gl
def test_a_png_written_to_stdout_is_only_the_png():
    """`render --out /dev/stdout | viewer`: the 'wrote' line goes to stderr, not into the PNG."""
    import io
    import subprocess
    import sys

    from PIL import Image

    run = subprocess.run([sys.executable, "-m", "isoscope", "render", "torus", "--size", "64x48", "--out",
                          "/dev/stdout"], capture_output=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert Image.open(io.BytesIO(run.stdout)).size == (64, 48)
    assert run.stdout.endswith(b"IEND\xaeB`\x82")
    assert run.stderr.decode().strip() == "wrote /dev/stdout (64x48)"


def test_a_ctrl_c_python_could_not_raise_still_ends_the_command():
    """A KeyboardInterrupt in a callback Python cannot raise from (a __del__, a gc callback: dask's, during a
    cluster export) printed 'Exception ignored' and was lost (exit 0); the entry point raises it again in
    the main thread (exit 130), and what the interrupted callback left broken prints nothing."""
    import subprocess
    import sys
    child = r'''
import sys, time
from isoscope.launch import main
import isoscope.cli.main as cli

class Interrupted:
    def __del__(self):
        raise KeyboardInterrupt

class LeftBroken:
    def __del__(self):
        raise AssertionError("state left half-way by the interrupt")

def runner(args):
    Interrupted()
    LeftBroken()
    for _ in range(500):
        time.sleep(0.01)
    return 0

cli.RUNNERS["volumes"] = runner
sys.argv = ["isoscope", "volumes"]
sys.exit(main())
'''
    run = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, timeout=60)
    assert run.returncode == 130 and run.stderr == "", (run.returncode, run.stderr[-2000:])


def test_control_characters_in_refusals_are_escaped(tmp_path):
    """A file name or a flag's value carrying ESC/BEL (clear screen, retitle the terminal) or a newline
    reaches stderr escaped, on one line."""
    name = tmp_path / "a\x1b]0;owned\x07\nb.npy"
    np.save(name, np.zeros((4, 4, 4), np.float32) + np.arange(4))
    for args in (("export", name, "--iso", "9", "--out", tmp_path / "m.ply"),
                 ("render", "sphere", "--out", tmp_path / "x.png", "--size", "8\x1b[2Jx9")):
        done = isoscope_here(*args)
        assert done.returncode == 2 and "\x1b" not in done.stderr and "\x07" not in done.stderr, done.stderr
        assert len(done.stderr.strip().splitlines()) == 1 and "\\x1b" in done.stderr
