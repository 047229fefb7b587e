"""Chunked extraction on a dask.distributed cluster: `isoscope export --scheduler ADDRESS / --workers N`.

One task per box (chunked.chunk_boxes).  Each worker process opens its own headless GL
context (EGL: the GPU if it has one, llvmpipe otherwise), one per worker thread, and
extracts its boxes with the GPU Extractor; the client gathers the boxes' meshes as they
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

_local = threading.local()
CONNECT_TIMEOUT_S = 10  # seconds to reach a scheduler before giving up


class ClusterError(RuntimeError):
    """The cluster could not run the extraction; the message is one line naming the fix."""


def _worker_context():
    """This worker thread's own standalone GL context (a context is current on one thread)."""
    if getattr(_local, "ctx", None) is None:
        from .gl_context import standalone
        _local.ctx = standalone()
    return _local.ctx


def _extract_task(source, box, level, spacing, descent):
    from .chunked import extract_box
    ctx = _worker_context()
    with ctx:
        return extract_box(source, box, level, spacing, descent, ctx)


def shippable(source):
    """A view of `source` cheap to send to workers: a memory map goes as its file's name (see Block3D)."""
    if isinstance(source, np.memmap):
        from .lazy_arrays import Block3D
        return Block3D(source)
    if isinstance(source, np.ndarray) and source.nbytes > 64 << 20:
        raise ClusterError("a dask cluster reads the volume from a file: save the array (np.save or Zarr) "
                           "and open it by path")
    return source


def connect(scheduler: str | None, workers: int | None):
    """A dask Client: to the scheduler at `scheduler`, else to a new LocalCluster of `workers` processes."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise ClusterError("--scheduler/--workers need dask.distributed: pip install 'isoscope[big]'") from None
    import logging
    if scheduler is None:
        cluster = LocalCluster(n_workers=workers or 2, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
        return Client(cluster)
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as exc:
        raise ClusterError(f"cannot reach the dask scheduler at {scheduler} ({exc}); check the address "
                           "and that `dask scheduler` is running there") from None


def marching_cubes_on_cluster(source, level: float, spacing, descent: bool, chunks, *, scheduler=None,
                              workers=None, progress=None):
    """verts, faces, normals, values of `source` (lazy or memory-mapped), extracted a box per task."""
    from dask.distributed import as_completed

    from .chunked import chunk_boxes, merge
    boxes = chunk_boxes(source.shape, chunks)
    client = connect(scheduler, workers)
    try:
        remote = client.scatter(shippable(source), broadcast=True)
        futures = [client.submit(_extract_task, remote, box, level, spacing, descent, pure=False)
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
