"""Chunked extraction on a dask.distributed cluster: `isoscope export --scheduler ADDRESS / --workers N`.

One task per box (chunked.chunk_boxes).  Each worker process opens its own headless GL
context (EGL: the GPU if it has one, llvmpipe otherwise), one per worker thread, and
extracts its boxes with the GPU Extractor (a worker with no OpenGL 4.3 uses the compiled
CPU extractor: the same mesh); the client gathers the boxes' meshes as they
finish (a progress callback per box) and merges them by global edge id (chunked.merge),
so the mesh is the one a single process makes.  Workers read the volume themselves: the
task carries a lazy view (a Zarr array, or a memory-mapped file named by path), never
the data.  Any failure (a worker dies, the scheduler cannot be reached) is a ClusterError
with one line naming it (the CLI's exit status 1).  Heavy imports are local: the CLI imports
this module for ClusterError on every command.
"""
from __future__ import annotations

import threading

import numpy as np

from ..errors import IsoscopeError

_local = threading.local()
CONNECT_TIMEOUT_S = 10  # seconds to reach a scheduler before giving up


PROBE_TIMEOUT_S = 3     # seconds for the scheduler to greet a new connection (dask's own greets at once)
MAX_GREETING_BYTES = 1 << 20
DASK_SCHEMES = ("tcp", "tls", "ucx", "ws", "wss", "inproc")  # a scheduler's handshake is a few hundred bytes


class ClusterError(IsoscopeError, RuntimeError):
    """The cluster could not run the extraction; the message is one line naming the fix."""
    exit_status = 1  # the machine or the network, not the input


class NotAScheduler(ClusterError):
    """The address answers, or stays silent, as no dask scheduler would: the address is wrong."""
    exit_status = 2


def _worker_context():
    """This worker thread's own standalone GL context (a context is current on one thread)."""
    if getattr(_local, "ctx", None) is None:
        from ..gpu.context import standalone
        _local.ctx = standalone()
    return _local.ctx


def _worker_backend(backend: str) -> str:
    """The backend this worker extracts with: "auto" is the GPU where the worker can open an OpenGL 4.3
    context on graphics hardware, else the compiled CPU extractor (the same mesh; gpu.context's
    one_shot_backend), decided once per worker thread."""
    if backend != "auto":
        return backend
    if getattr(_local, "backend", None) is None:
        from ..gpu.context import GLUnavailable, one_shot_backend_on
        try:
            _local.backend = one_shot_backend_on(_worker_context())
        except GLUnavailable:
            _local.backend = "cpu"
    return _local.backend


def _extract_task(source, box, level, spacing, descent, backend="auto", topology="montani"):
    from .chunked import extract_box
    backend = _worker_backend(backend)
    if backend != "gpu":
        return extract_box(source, box, level, spacing, descent, backend=backend, topology=topology)
    ctx = _worker_context()
    with ctx:
        return extract_box(source, box, level, spacing, descent, ctx, topology=topology)


def mapped_npy(source, path):
    """`source` as a memory map of the .npy file at `path` when that file holds exactly it (same shape,
    type and C order: the file opened by path, small enough to have been read whole), else `source`."""
    if path is None or not isinstance(source, np.ndarray) or isinstance(source, np.memmap) \
            or not str(path).lower().endswith(".npy"):
        return source
    try:
        mapped = np.load(path, mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError, EOFError):
        return source
    if isinstance(mapped, np.memmap) and mapped.shape == source.shape and mapped.dtype == source.dtype \
            and mapped.flags.c_contiguous:
        return mapped
    return source


def shippable(source, path=None):
    """A view of `source` cheap to send to workers: a memory map goes as its file's name (see Block3D),
    and so does an array read whole from the .npy file at `path`."""
    source = mapped_npy(source, path)
    if isinstance(source, np.memmap):
        from ..core.lazy_arrays import Block3D
        return Block3D(source)
    if isinstance(source, np.ndarray) and source.nbytes > 64 << 20:
        raise ClusterError("a dask cluster reads the volume from a file: save the array (np.save or Zarr) "
                           "and open it by path")
    return source


def connect(scheduler: str | None, workers: int | None):
    """A dask Client: to the scheduler at `scheduler`, else to a new LocalCluster of `workers` processes.

    dask's log lines stay off stderr (failures come back as one ClusterError line); a local cluster has
    no dashboard (no "Port 8787 is already in use") and its worker processes never see SIGINT, so a
    Ctrl-C reaches this process alone and ends it with no traceback from each worker."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise ClusterError("--scheduler/--workers need dask.distributed: pip install 'isoscope[big]'") from None
    import logging
    import warnings
    quiet = logging.getLogger("distributed")  # no dask log lines: failures come back as one ClusterError line
    quiet.setLevel(logging.CRITICAL + 1)
    for handler in quiet.handlers:  # its children (distributed.client ...) have levels of their own
        handler.setLevel(logging.CRITICAL + 1)
    # "Port 8787 is already in use ... Hosting the HTTP server on port N instead": the scheduler's HTTP
    # server (health, metrics) takes port 8787 even with no dashboard.
    warnings.filterwarnings("ignore", module=r"distributed(\.|$)")
    if scheduler is None:
        cluster = LocalCluster(n_workers=0, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.CRITICAL + 1)
        try:
            client = Client(cluster)
            _start_workers_deaf_to_sigint(cluster, workers or 2)
            try:
                client.wait_for_workers(workers or 2, timeout=WORKERS_TIMEOUT_S)
            except TimeoutError:
                raise ClusterError(f"the local dask workers did not start within {WORKERS_TIMEOUT_S} s; try fewer "
                                   "--workers, or check memory") from None
            return client
        except BaseException:
            cluster.close()
            raise
    probe_scheduler(scheduler)
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as exc:
        raise ClusterError(f"cannot reach the dask scheduler at {scheduler} ({_first_line(exc)}); check the "
                           "address and that `dask scheduler` is running there") from None
    except (MemoryError, ValueError, TypeError, KeyError, *_unpack_errors()) as exc:  # a reply dask could not read
        raise NotAScheduler(f"{scheduler} did not answer as a dask scheduler ({type(exc).__name__}: "
                            f"{_first_line(exc)}); check the address (dask schedulers listen on port 8786 "
                            "by default)") from None


def _unpack_errors() -> tuple[type[Exception], ...]:
    """msgpack's errors for bytes that are not its messages (some are not ValueErrors)."""
    try:
        from msgpack import UnpackException
    except ImportError:
        return ()
    return (UnpackException,)


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0][:200] if text else type(exc).__name__


WORKER_PROCESS = "Dask Worker process"  # the name dask's Nanny gives the processes it spawns
SPAWN_TIMEOUT_S = 30
WORKERS_TIMEOUT_S = 120


def _start_workers_deaf_to_sigint(cluster, workers: int) -> None:
    """Scale `cluster` to `workers` processes that never see SIGINT, so that a Ctrl-C ends this process
    alone (exit 130) instead of printing a traceback from every worker.

    SIGINT is ignored here just while the processes are spawned: an ignored signal stays ignored across
    exec, and Python then installs no KeyboardInterrupt handler in them.  A handled or blocked one would
    not do: exec resets handlers, and a blocked signal is taken by a thread that does not block it (numpy's
    BLAS threads) and dropped.  The window in which a Ctrl-C here is lost is the spawn itself, not the
    worker's start-up (seconds of imports); it is waited for after the handler is back.  Main thread only
    (signal.signal's rule); from another thread the workers are started as dask starts them."""
    import multiprocessing
    import signal
    import time
    if threading.current_thread() is not threading.main_thread():
        cluster.scale(workers)
        return

    def spawned() -> int:
        """How many worker processes this process has started and that are still running."""
        return sum(child.name.startswith(WORKER_PROCESS) for child in multiprocessing.active_children())

    handler = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        cluster.scale(workers)
        deadline = time.monotonic() + SPAWN_TIMEOUT_S
        while spawned() < workers and time.monotonic() < deadline:
            time.sleep(0.01)
    finally:
        signal.signal(signal.SIGINT, handler)


def probe_scheduler(address: str, timeout: float = PROBE_TIMEOUT_S) -> None:
    """Refuse, within `timeout` seconds, a tcp:// address that is not a dask scheduler.

    dask.distributed's Client waits without end on a server that never greets it (an HTTP server waits
    for a request: >120 s), and reads a garbage reply's first 8 bytes as a length to allocate ("Unable
    to allocate 3.07 EiB").  A dask scheduler greets a new connection at once with its handshake: an
    8-byte length, then that many bytes of frames.  Other schemes (tls://, ucx://) are left to dask."""
    import socket
    import struct
    import time
    scheme, _, location = address.rpartition("://")
    if scheme not in ("", "tcp"):
        if scheme not in DASK_SCHEMES:
            raise NotAScheduler(f"--scheduler {address}: a dask scheduler's address is tcp://HOST:PORT (or "
                                f"{', '.join(s + '://' for s in DASK_SCHEMES[1:])}), not {scheme}://; e.g. "
                                "tcp://10.0.0.5:8786")
        return
    host, _, port = location.rpartition(":")
    host = host.strip("[]") or "127.0.0.1"
    if not port.isdigit() or not 0 < int(port) < 65536:
        raise NotAScheduler(f"--scheduler {address!r} has no port (1-65535); give HOST:PORT, e.g. "
                            "tcp://10.0.0.5:8786")
    deadline = time.monotonic() + timeout
    try:
        sock = socket.create_connection((host, int(port)), timeout=timeout)
    except OSError as exc:  # refused, unreachable, no such host, or no answer to the connect in time
        raise ClusterError(f"cannot reach the dask scheduler at {address} ({exc.strerror or 'timed out'}); "
                           "check the address and that `dask scheduler` is running there") from None
    try:
        with sock:
            (length,) = struct.unpack("<Q", _receive(sock, 8, deadline))
            if not 0 < length <= MAX_GREETING_BYTES:
                raise NotAScheduler(f"{address} did not answer as a dask scheduler (its first bytes are no dask "
                                    "handshake); check the address (dask schedulers listen on port 8786 by default)")
            greeting = _receive(sock, length, deadline)
    except TimeoutError:
        raise NotAScheduler(f"{address} did not greet as a dask scheduler within {timeout:g} s (an HTTP or other "
                            "server?); check the address (dask schedulers listen on port 8786 by default)") from None
    except OSError as exc:  # reset by the peer
        raise NotAScheduler(f"{address} broke off the connection ({exc.strerror or exc}) as no dask scheduler "
                            "does; check the address") from None
    try:
        from distributed.protocol.utils import unpack_frames
        unpack_frames(greeting, partial=True)
    except Exception:
        raise NotAScheduler(f"{address} did not answer as a dask scheduler (its handshake does not parse); check "
                            "the address (dask schedulers listen on port 8786 by default)") from None


def _receive(sock, count: int, deadline: float) -> bytes:
    import time
    parts, left = [], count
    while left:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError
        sock.settimeout(remaining)
        part = sock.recv(min(left, 1 << 16))
        if not part:
            raise NotAScheduler(f"the server closed the connection after {count - left} of {count} bytes, as "
                                "no dask scheduler does; check the --scheduler address")
        parts.append(part)
        left -= len(part)
    return b"".join(parts)


def marching_cubes_on_cluster(source, level: float, spacing, descent: bool, chunks, *, scheduler=None,
                              workers=None, progress=None, path=None, backend="auto", topology="montani"):
    """verts, faces, normals, values of `source` (lazy or memory-mapped), extracted a box per task;
    `path`, the .npy file `source` was read from, lets workers read it themselves whatever its size.
    `backend`: "gpu", "cpu", "numpy", or "auto" (each worker the GPU where it can open a GL context,
    else the CPU: the same mesh either way); `topology`: of the ambiguous cells, as chunked.extract_box."""
    from dask.distributed import as_completed

    from .chunked import chunk_boxes, merge
    boxes = chunk_boxes(source.shape, chunks)
    client = connect(scheduler, workers)
    try:
        remote = client.scatter(shippable(source, path), broadcast=True)
        futures = [client.submit(_extract_task, remote, box, level, spacing, descent, backend, topology, pure=False)
                   for box in boxes]
        parts, pending = [], as_completed(futures)
        del futures  # each result is held by the cluster only until this client has it
        for done, future in enumerate(pending, 1):
            try:
                parts.append(future.result())
                future.release()
            except Exception as exc:  # KilledWorker, a worker's GL failure, a lost connection
                raise ClusterError(f"a dask worker failed on a chunk ({type(exc).__name__}: "
                                   f"{str(exc).splitlines()[0] if str(exc) else ''}); nothing was written") from None
            if progress is not None:
                progress(done / len(boxes), f"extracting chunk {done}/{len(boxes)}")
        return merge(parts, source.shape)
    finally:
        cluster = client.cluster
        client.close()
        if cluster is not None and scheduler is None:
            cluster.close()
